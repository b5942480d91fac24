// irdm validate-converged: the probe scenes on a converged discretization.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/converged_validation.h>

#include <iostream>
#include <memory>

namespace irdm::cli
{
  Command
  add_validate_converged(CLI::App &app)
  {
    auto vc = std::make_shared<irdm::validation::ConvergedValidationOptions>();
    auto *validate_converged = app.add_subcommand(
      "validate-converged", "the probe scenes on the coarse cat and on a converged discretization: "
                            "method error and discretization error; reports/converged");
    validate_converged->footer(
      "Gives each probe of the named scenes a contact radius (--radius), then runs every scene "
      "on its own discretization (coarse) and on --converged-mesh at --converged-degree, each "
      "through the linear FEM and through IRDM from a model of that discretization (coarse: "
      "every mode, exact; converged: the lowest --modes modes plus residual modes, sparse "
      "route). Reports the method error (IRDM against the same FEM) and the discretization "
      "error (each FEM and model against the converged FEM) apart, with each discretization's "
      "driving-point stiffness against --extrapolated-stiffness. Writes DIR/converged/ "
      "(converged.csv, series.csv, report.md). scripts/converged.sh makes the converged mesh "
      "and reads the extrapolated stiffness from reports/convergence/. Units SI.");
    validate_converged->add_option("--scenes", vc->scenes_dir, "scene folder")
      ->capture_default_str()
      ->check(CLI::ExistingDirectory);
    validate_converged->add_option("--scene", vc->scenes, "scene names (repeatable or comma-separated)")
      ->delimiter(',')
      ->capture_default_str();
    validate_converged->add_option("--converged-mesh", vc->converged_mesh,
                                   "gmsh mesh of the converged discretization (for example "
                                   "cat_lc3.4mm.msh from meshes/generate.sh --study)")
      ->required()
      ->check(CLI::ExistingFile);
    validate_converged->add_option("--converged-degree", vc->converged_degree, "FE degree on it")
      ->capture_default_str()
      ->check(CLI::Range(1u, 2u));
    validate_converged->add_option("--radius", vc->probe_radius, "probes' contact radius (m)")
      ->capture_default_str()
      ->check(CLI::Range(1e-4, 1.0));
    validate_converged->add_option("--extrapolated-stiffness", vc->extrapolated_stiffness,
                                   "mesh-converged driving-point stiffness of the first probe "
                                   "of --extrapolated-scene (N/m; 0: not stated)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e12));
    validate_converged->add_option("--extrapolated-scene", vc->extrapolated_scene,
                                   "the scene whose first probe --extrapolated-stiffness belongs "
                                   "to (compared with the scenes whose first probe starts at "
                                   "the same point along the same direction)")
      ->capture_default_str();
    validate_converged->add_option("--modes", vc->modes, "lowest modes of the converged model")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    validate_converged->add_option("--out", vc->report_dir, "report folder")->capture_default_str();
    validate_converged->add_option("--models", vc->model_dir,
                                   "folder for the working models (removed after use)")
      ->capture_default_str();
    return {validate_converged, [vc] {
               irdm::check_output_folder("--out", vc->report_dir);
               irdm::check_output_folder("--models", vc->model_dir);
               irdm::validation::run_converged_validation(*vc, std::cout);
               return 0;
             }};
  }
} // namespace irdm::cli
