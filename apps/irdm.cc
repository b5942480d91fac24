// irdm: one command-line program with subcommands, parsed by CLI11 (typed options with ranges:
// "--max-delay 10.9" is refused, never truncated). Each subcommand lives in its own file,
// apps/commands/<name>.cc. Exit status (docs/exit-codes.md): 0 ok, 1 internal error, 2 bad
// input, usage or a refusal, 3 a check failed, 4 a read or write failed.
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include "command.h"

#include <deal.II/base/mpi.h>

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace
{
  // With several MPI ranks, an error on one rank must stop all of them, not hang the rest.
  void
  abort_other_ranks()
  {
    int size = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    if (size > 1)
      MPI_Abort(MPI_COMM_WORLD, 2);
  }

  int
  run(int argc, char **argv)
  {
    using namespace irdm::cli;
    set_invocation(argc, argv);
    CLI::App app{"irdm: impulse response deformation model (IRDM) validation harness.\n"
                 "Units are SI throughout. Scene files: docs/scene-format.md; result files: "
                 "docs/fem-output.md; models: docs/model-format.md; exit codes: "
                 "docs/exit-codes.md.",
                 "irdm"};
    app.require_subcommand(1);
    app.fallthrough(false);
    const std::vector<Command> commands = {
      add_simulate(app),        add_static(app),          add_modes(app),
      add_probe_stiffness(app), add_verify_fem(app),      add_precompute(app),
      add_precompute_vdof(app), add_compress(app),        add_compare_models(app),
      add_export(app),          add_import(app),          add_calculix(app),
      add_validate(app),        add_validate_planes(app), add_validate_free(app),
      add_validate_converged(app), add_validate_nonlinear(app), add_play(app)};

    try
      {
        app.parse(argc, argv);
      }
    catch (const CLI::ParseError &e)
      {
        // Help and version are not errors; everything else is a usage error (exit 2).
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
      }

    for (const Command &c : commands)
      if (c.app->parsed())
        {
          // Only the precomputes deal work to MPI ranks; any other command would run N times
          // and race on its outputs.
          int size = 1;
          MPI_Comm_size(MPI_COMM_WORLD, &size);
          if (size > 1 && !c.parallel)
            {
              if (mpi_rank() == 0)
                std::fprintf(stderr, "irdm: error: '%s' does not run in parallel; run it without "
                                     "mpirun (only precompute and precompute-vdof use MPI ranks)\n",
                             c.app->get_name().c_str());
              return 2;
            }
          return c.run();
        }
    return 2; // not reached: CLI11 requires one subcommand
  }
} // namespace

namespace
{
  // All our files are closed by now (RAII). After a failed HDF5 close, HDF5's own cleanup at
  // MPI_Finalize would crash on that file (irdm::h5::a_close_failed()): end here instead.
  int
  finish(const int status)
  {
    if (irdm::h5::a_close_failed())
      {
        std::fflush(stdout);
        std::fflush(stderr);
        std::_Exit(status);
      }
    return status;
  }

  int
  run_reporting_errors(int argc, char **argv)
  {
    try
      {
        return run(argc, argv);
      }
    catch (const irdm::InputError &e)
      {
        std::fprintf(stderr, "irdm: error: %s\n", e.what());
        abort_other_ranks();
        return 2;
      }
    catch (const irdm::IoError &e)
      {
        std::fprintf(stderr, "irdm: error: %s\n", e.what());
        abort_other_ranks();
        return 4;
      }
    catch (const std::exception &e)
      {
        std::fprintf(stderr, "irdm: internal error: %s\n", e.what());
        abort_other_ranks();
        return 1;
      }
  }
} // namespace

int
main(int argc, char **argv)
{
  dealii::Utilities::MPI::MPI_InitFinalize mpi(argc, argv, 1);
  return finish(run_reporting_errors(argc, argv));
}
