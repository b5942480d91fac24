// What several irdm commands share.
#include "../command.h"

#include <irdm_common/files.h>
#include <reference_fem/scene.h>

#include <mpi.h>

#include <chrono>
#include <cstdio>

namespace irdm::cli
{
  void
  print_progress(const double fraction)
  {
    using Clock                = std::chrono::steady_clock;
    static const auto start    = Clock::now();
    const double      elapsed  = std::chrono::duration<double>(Clock::now() - start).count();
    const double      left     = fraction > 0 ? elapsed * (1 - fraction) / fraction : 0;
    std::fprintf(stderr, "\r  %3.0f %%, %.0f s elapsed, about %.0f s left   ", 100 * fraction,
                 elapsed, left);
    if (fraction >= 1)
      std::fprintf(stderr, "\n");
  }

  std::function<void(const std::string &)>
  stderr_log(const bool quiet)
  {
    if (quiet)
      return {};
    return [](const std::string &s) { std::fprintf(stderr, "  %s\n", s.c_str()); };
  }

  int
  mpi_rank()
  {
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    return rank;
  }

  void
  check_scene_outputs(const irdm::fem::Scene &scene)
  {
    if (scene.outputs.directory.empty())
      std::fprintf(stderr, "note: the scene has no outputs.directory, so nothing is written "
                           "(only the summary below)\n");
    else
      irdm::check_output_folder("outputs.directory", scene.outputs.directory);
  }

  std::optional<bool>
  storage_choice(const std::string &s)
  {
    if (s.empty())
      return std::nullopt;
    return s == "double";
  }

  const char *const storage_help = "float or double (overrides the scene's model.storage)";

  namespace
  {
    std::string &
    invocation_text()
    {
      static std::string text;
      return text;
    }
  } // namespace

  void
  set_invocation(const int argc, char **argv)
  {
    std::string &text = invocation_text();
    text.clear();
    for (int i = 0; i < argc; ++i)
      {
        std::string a = argv[i];
        if (a.find_first_of(" '\"") != std::string::npos)
          {
            std::string quoted = "'";
            for (const char c : a)
              quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
            a = quoted + "'";
          }
        text += (i ? " " : "") + a;
      }
  }

  const std::string &
  invocation()
  {
    return invocation_text();
  }
} // namespace irdm::cli
