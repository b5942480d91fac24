#pragma once
// The irdm program's subcommands. Each lives in its own file, apps/commands/<name>.cc: it adds
// its options to the program and says what runs once they are parsed. Exit statuses:
// docs/exit-codes.md.
#include <CLI/CLI.hpp>

#include <functional>
#include <optional>
#include <string>

namespace irdm::fem
{
  struct Scene;
}

namespace irdm::cli
{
  struct Command
  {
    CLI::App            *app = nullptr;
    std::function<int()> run;              // the exit status
    bool                 parallel = false; // deals its work to MPI ranks (mpirun -np N)
  };

  /// The command line this run was given (argv joined, each argument with a space or a
  /// quote in quotes): what a report says reproduces it.
  void
  set_invocation(int argc, char **argv);
  const std::string &
  invocation();

  Command
  add_simulate(CLI::App &app);
  Command
  add_static(CLI::App &app);
  Command
  add_modes(CLI::App &app);
  Command
  add_probe_stiffness(CLI::App &app);
  Command
  add_verify_fem(CLI::App &app);
  Command
  add_precompute(CLI::App &app);
  Command
  add_precompute_vdof(CLI::App &app);
  Command
  add_compress(CLI::App &app);
  Command
  add_compare_models(CLI::App &app);
  Command
  add_export(CLI::App &app);
  Command
  add_import(CLI::App &app);
  Command
  add_calculix(CLI::App &app);
  Command
  add_validate(CLI::App &app);
  Command
  add_validate_planes(CLI::App &app);
  Command
  add_validate_free(CLI::App &app);
  Command
  add_validate_converged(CLI::App &app);
  Command
  add_validate_nonlinear(CLI::App &app);
  Command
  add_play(CLI::App &app);

  // What several commands share (apps/commands/common.cc).

  /// "  45 %, 12 s elapsed, about 15 s left" on stderr (the estimate assumes the rest goes as
  /// fast).
  void
  print_progress(double fraction);
  /// Progress lines on stderr, or none when quiet.
  std::function<void(const std::string &)>
  stderr_log(bool quiet);
  int
  mpi_rank();
  /// The scene's output folder, checked before the work; a word if there is none.
  void
  check_scene_outputs(const irdm::fem::Scene &scene);
  /// --storage: float, double, or (empty) the scene's model.storage.
  std::optional<bool>
  storage_choice(const std::string &s);
  extern const char *const storage_help;
} // namespace irdm::cli
