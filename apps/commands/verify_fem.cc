// irdm verify-fem: the reference FEM against theory, a report written.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/fem_verification.h>

#include <iostream>
#include <memory>

namespace irdm::cli
{
  Command
  add_verify_fem(CLI::App &app)
  {
    auto vf = std::make_shared<irdm::validation::FemVerificationOptions>();
    auto *verify = app.add_subcommand("verify-fem", "FEM verification suite against theory; writes a report");
    verify->footer("Runs the reference-FEM verification suite (cantilever frequency and convergence, static "
      "tip deflection, energy conservation and dissipation, gravity reaction, damping, "
      "prescribed displacement reaction; nonlinear mode: a ball's peak contact force against "
      "Hertz over impact speed, mesh and penalty) and writes a Markdown report with CSV data "
      "under --out; about 10 min on 2 cores (--quick: 1.5 min). Exit code 0: every check "
      "passed; 3: some check failed (the report says which).");
    verify->add_option("--meshes", vf->mesh_dir, "folder with the project's meshes")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    verify->add_option("--out", vf->report_dir, "report folder")->capture_default_str();
    verify->add_flag("--quick", vf->quick,
                     "skip the finest beam and ball meshes and most impact speeds (for a fast "
                     "look; the report says so)");
    return {verify, [vf] {
               irdm::check_output_folder("--out", vf->report_dir);
               return irdm::validation::run_fem_verification(*vf, std::cout) ? 0 : 3;
             }};
  }
} // namespace irdm::cli
