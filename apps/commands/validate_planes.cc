// irdm validate-planes: plane contact against the nonlinear FEM.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/plane_validation.h>

#include <iostream>
#include <memory>
#include <string>

namespace irdm::cli
{
  Command
  add_validate_planes(CLI::App &app)
  {
    auto vp = std::make_shared<irdm::validation::PlaneValidationOptions>();
    auto *validate_planes = app.add_subcommand("validate-planes", "plane contact (virtual DOFs, many-vertex contact) against the nonlinear FEM; reports/planes");
    validate_planes->footer("Plane contact against the nonlinear reference FEM on the grounded cat, by virtual "
      "DOFs (seed 001; vdof_nearest, vdof_interpolated) and by many-vertex contact "
      "(vertex_contact_modal, vertex_contact_direct): a wall pressing from the side, from "
      "the top, from two directions between the dome's, and two walls at once, at depths 2 to "
      "20 mm; a tilted side wall turning while held, so that its contact patch slides; and "
      "hitting the side at 0.05 to 0.5 m/s (2 mm deep). Then compliant walls over "
      "--stiffness-sweep on four cases, and the orientation mappings compared (nearest, "
      "interpolated, interpolated_same_contact). Precomputes the virtual-DOF "
      "model and the every-surface-vertex model first, or reuses --model and --vertex-model "
      "when made from the same scene and spec (an existing file of another kind or spec is "
      "refused, never overwritten). Writes DIR/planes/planes.md, planes.csv (one row per case "
      "and method), cases.csv, forces.csv, stiffness.csv, mapping.csv, planes.png and "
      "stiffness.png.");
    validate_planes->add_option("--scene", vp->scene, "the body (its probes are ignored)")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
    validate_planes->add_option("--out", vp->report_dir, "report folder")->capture_default_str();
    validate_planes->add_option("--model", vp->model_file, "virtual-DOF model")->capture_default_str();
    validate_planes->add_option("--subdivisions", vp->subdivisions, "dome subdivisions")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4u));
    validate_planes->add_option("--length", vp->length,
                                "samples per response (the longest case is 0.6 s)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    validate_planes->add_option("--vertex-model", vp->vertex_model_file,
                                "many-vertex contact model (every free surface vertex)")
      ->capture_default_str();
    validate_planes->add_option("--margin", vp->margin,
                                "m; vertices within it of a wall are contact candidates")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
    validate_planes->add_option("--max-candidates", vp->max_candidates,
                                "candidate vertices per step, at most")
      ->capture_default_str()
      ->check(CLI::Range(1u, 20000u));
    validate_planes->add_option("--surface-modes", vp->surface_modes,
                                "modes of the modal surface update (the force loop uses all)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1000000u));
    validate_planes->add_option("--vertex-stiffness", vp->vertex_stiffness,
                                "N/m per vertex of vertex contact's walls in the main table; "
                                "-1: the FEM penalty's per-vertex equivalent; 0: rigid")
      ->capture_default_str()
      ->check(CLI::Range(-1.0, 1e12));
    validate_planes->add_option("--stiffness-sweep", vp->stiffness_sweep,
                                "N/m; compliant-wall stiffnesses tried on the sweep cases (0: rigid)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e12));
    validate_planes->add_flag("!--no-direct", vp->direct,
                              "skip vertex_contact_direct (its H needs GBs of memory)");
    validate_planes->add_option("--perturbations", vp->perturbations,
                                "runs of every method with the walls' penetration, speed or "
                                "stiffness scaled by 1 + eps, eps = +-1e-6 or +-1e-3 in turn, for "
                                "the range of each error (spread.csv; 0: none)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000u));
    validate_planes->add_flag("--corotational,!--no-corotational", vp->corotational,
                              "also run the FEM with the corotational law (each point's own "
                              "rotation) and the small-strain law on every case, the truth's own "
                              "contact, and split the linear law's miss into rotation and strain "
                              "(cases.csv); on by default")
      ->capture_default_str();
    validate_planes->add_option("--converged-degree", vp->converged_degree,
                                "the truth's own discretization error: on --converged-cases, the "
                                "nonlinear FEM again with elements of this degree on the same "
                                "mesh or on --converged-mesh, and every run scored against it "
                                "beside the P1 truth (converged.csv); 0: not run (default: 2, "
                                "1 with --converged-mesh)")
      ->check(CLI::IsMember({0u, 1u, 2u}));
    validate_planes->add_option("--converged-mesh", vp->converged_mesh,
                                "the converged truth on this finer gmsh mesh of the body (for "
                                "example meshes/cat_fine.msh; each wall's depth from its own "
                                "outermost point)")
      ->check(CLI::ExistingFile);
    validate_planes->add_option("--converged-cases", vp->converged_cases,
                                "the cases of --converged-degree")
      ->capture_default_str();
    validate_planes->add_option("--reduced-model", vp->reduced_models,
                                "reduced nonlinear models of the scene's body (irdm precompute "
                                "--reduced), each a method reduced_<file stem> on every case")
      ->check(CLI::ExistingFile);
    validate_planes->add_option("--reduced-newton-tolerance", vp->reduced_newton_tolerance,
                                "the reduced models' Newton stop: the residual within this "
                                "fraction of its largest force")
      ->capture_default_str()
      ->check(CLI::Range(1e-14, 1e-2));
    validate_planes->add_option("--cases", vp->cases,
                                "only these cases, each a case name (press_top_5mm) or a kind "
                                "(press_top_and_side, slide_side); default: every case");
    validate_planes->add_flag("--quick", vp->quick,
                              "15 of the 22 cases: every kind and the sweep's cases, at fewer "
                              "depths and speeds (the main job's default)");
    return {validate_planes, [vp, validate_planes] {
               irdm::check_output_folder("--out", vp->report_dir);
               if (!vp->converged_mesh.empty() && validate_planes->count("--converged-degree") == 0)
                 vp->converged_degree = 1;
               vp->plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_planes.py";
               irdm::validation::run_plane_validation(*vp, std::cout);
               return 0;
             }};
  }
} // namespace irdm::cli
