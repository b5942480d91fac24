// irdm validate-free: the free cat against the nonlinear FEM.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/free_body_validation.h>

#include <iostream>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    // The FEM runs beside the truth: its check at half the step, the linear and corotational
    // laws, the sensitivity and the converged (P2) truth.
    void
    add_reference_options(CLI::App &app, irdm::validation::FreeBodyValidationOptions &o)
    {
      app.add_flag("--truth-check", o.truth_check,
                              "also run the FEM at half its step (tau / 2M) and compare it with "
                              "the FEM at tau / M by the same measures (truth.csv): how well the "
                              "truth itself is determined; triples the FEM's time. The linear FEM "
                              "too (linearization.csv, method <linear FEM>_half_step): how well "
                              "the method's reference is");
      app.add_flag("--sensitivity", o.sensitivity,
                              "also run the linear FEM with the floor 1 um lower and compare it with "
                              "the linear FEM by the same measures (linearization.csv, method "
                              "<linear FEM>_floor_1um): where a change so small moves a figure as "
                              "much as the method's error, the scene decides that figure, not the "
                              "method; doubles the linear FEM's time");
      app.add_option("--sensitivity-um", o.sensitivity_um,
                                "with --sensitivity: the floor's shifts (micrometres), one linear FEM "
                                "run each (method <linear FEM>_floor_<x>um); a shift whose first "
                                "contact moves as much as the method's error measures how far the "
                                "scene amplifies that error over the run")
        ->capture_default_str()
        ->check(CLI::Range(1e-3, 1e4));
      app.add_flag("--small-strain,!--no-small-strain", o.small_strain,
                              "also run the FEM with a linear law (--linear-law) and report linear "
                              "elasticity's own error (it against the truth) and the method's (the "
                              "runtime against it) apart (linearization.csv); on by default")
        ->capture_default_str();
      app.add_flag("--corotational,!--no-corotational", o.corotational,
                              "also run the FEM with the corotational law (fem_corotational: the "
                              "small-strain law in each point's own rotation) and split each miss "
                              "of the linear FEM into rotation (the linear FEM against it) and "
                              "strain (it against the truth) (linearization.csv); on by default")
        ->capture_default_str();
      app.add_option("--converged-degree", o.converged_degree,
                                "the truth's own discretization error: on --converged-cases, the "
                                "nonlinear FEM again with P2 elements on the same mesh (or P1 or "
                                "P2 on --converged-mesh), the P1 truth and every run against it "
                                "(linearization.csv, reference fem_neo_hookean_p<degree>[_<mesh>]); "
                                "0: not run")
        ->capture_default_str()
        ->check(CLI::IsMember({0u, 1u, 2u}));
      app.add_option("--converged-mesh", o.converged_mesh,
                                "a finer gmsh mesh of the same body for that truth (P1 on it unless "
                                "--converged-degree says otherwise): the planes moved by the two "
                                "bodies' difference in reach, its surface read at the closest point "
                                "to each surface vertex; cases without a probe")
        ->check(CLI::ExistingFile);
      app.add_option("--converged-check-mesh", o.converged_check_meshes,
                                "other meshes of the body (coarser than --converged-mesh): the "
                                "truth again on each, as on --converged-mesh, and scored against "
                                "that truth (linearization.csv, method "
                                "fem_neo_hookean_p<degree>_<mesh>, reference the converged "
                                "truth): whether the converged truth is converged")
        ->check(CLI::ExistingFile);
      app.add_option("--converged-cases", o.converged_cases,
                                "the cases of --converged-degree (every material of the run)")
        ->capture_default_str()
        ->check(CLI::IsMember({"drop_2cm", "drop_5cm", "drop_10cm", "spin_roll", "wall_throw",
                               "tilted_5cm", "probe_push"}));
      app.add_option_function<std::string>(
          "--linear-law",
          [&o](const std::string &law) { o.body_frame = law == "linear_body_frame"; },
          "that linear FEM's law: linear_body_frame (the default: the small-strain law in the "
          "body's best-fit frame, run fem_linear_body_frame) or linear (the plain small-strain "
          "law, not objective: a spin swells its body instead of turning it; run fem_small_strain, "
          "not for spin_roll)")
        ->check(CLI::IsMember({"linear_body_frame", "linear"}));
    }
  } // namespace

  Command
  add_validate_free(CLI::App &app)
  {
    auto vfb = std::make_shared<irdm::validation::FreeBodyValidationOptions>();
    auto *validate_free = app.add_subcommand("validate-free", "the free cat dropped, tilted, spinning and thrown at a wall, against the nonlinear FEM; reports/free");
    validate_free->footer("Precomputes the free-body models of --scene (no fixed surface) by both "
      "routes (route 1: the recorded response minus its best rigid fit, uniform weights; route "
      "2: the rigid-body modes removed) for each Young's modulus of --materials, then runs every "
      "case through the nonlinear FEM (neo-Hookean, penalty planes) and FreeBodyInteraction "
      "(rigid body + modal deformation, many-vertex contact with the FEM's penalty, each "
      "vertex weighed by its lumped area; a probe's force as a known point force) with each model, and through FreeBodyVirtualDofs with the seed's virtual "
      "DOFs of the free body (irdm precompute-vdof on it; the precompute's penalty walls): drops from 2, 5 and 10 cm, a drop with a spin (2 s), a "
      "throw at a wall, a drop on a floor tilted 25 degrees, and a push by a probe (the "
      "virtual DOFs take no probe); then the runtime alone rolls "
      "for --stability seconds and flies free for 10 s. Writes DIR/free/free.csv (one row per "
      "case, material and method), first_contact.csv (the same measures over the first "
      "contact alone), truth_strain.csv (the truth's largest strain), truth.csv (with --truth-check), linearization.csv (the linear "
      "FEM against the truth, the runtime against the linear FEM), series.csv (forces, heights, angles and "
      "deformation against time, each method's, the linear FEM's and the finer truths' beside the truth's), "
      "frames.csv and triangles.csv (surfaces of the rolling cat), fig6.png, frames.png and "
      "report.md. Units SI.");
    validate_free->add_option("--scene", vfb->scene, "the free body")
      ->capture_default_str()
      ->check(CLI::ExistingFile);
    validate_free->add_option("--out", vfb->report_dir, "report folder")->capture_default_str();
    validate_free->add_option("--model-dir", vfb->model_dir, "folder of the free models (written)")
      ->capture_default_str();
    validate_free->add_option("--materials", vfb->materials,
                              "Young's moduli (Pa), space- or comma-separated")
      ->capture_default_str()
      ->delimiter(',')
      ->check(CLI::Range(1.0, 1e12));
    validate_free->add_option("--fem-divisions", vfb->fem_divisions,
                              "the truth's step: the nonlinear FEM runs at tau / M, sampled at "
                              "tau; one M for every material, or one per material of "
                              "--materials (default: 4 below 10 kPa, where the soft truth at "
                              "tau gains energy, else 1)")
      ->delimiter(',')
      ->check(CLI::Range(1u, 64u));
    validate_free->add_option("--duration", vfb->duration, "seconds per case")
      ->capture_default_str()
      ->check(CLI::Range(0.002, 100.0));
    validate_free->add_option("--surface-modes", vfb->surface_modes,
                              "modes in the surface update; 0: every mode")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--study-surface-modes", vfb->study_surface_modes,
                              "the impact study also runs route 2 with this many modes in its "
                              "surface (route2_modal_s<M>); 0: not run")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--stability", vfb->stability_seconds,
                              "seconds of rolling for the runtime's stability run")
      ->capture_default_str()
      ->check(CLI::Range(0.002, 3600.0));
    validate_free->add_flag("--quick", vfb->quick, "the 5 cm drop and the tilted drop only");
    validate_free->add_option("--force-modes", vfb->force_modes,
                              "each route also with K modes in the force loop (the rest "
                              "quasi-static): methods route1_rigid_fit_k<K> and route2_modal_k<K>; 0: not run")
      ->capture_default_str()
      ->check(CLI::Range(0u, 100000u));
    validate_free->add_option("--cases", vfb->only_cases,
                              "run only these cases: drop_2cm, drop_5cm, drop_10cm, spin_roll, "
                              "wall_throw, tilted_5cm, probe_push, and impact (the impact "
                              "study, which a full run includes)")
      ->delimiter(',')
      ->check(CLI::IsMember({"drop_2cm", "drop_5cm", "drop_10cm", "spin_roll", "wall_throw",
                             "tilted_5cm", "probe_push", "impact"}));
    validate_free->add_option("--reduced-model", vfb->reduced_models,
                              "reduced nonlinear models of the free body (irdm precompute --reduced "
                              "on its scene at a material's Young's modulus), each a method "
                              "reduced_<file stem> on that material's cases")
      ->check(CLI::ExistingFile);
    validate_free->add_flag("--reduced-one-frame", vfb->reduced_one_frame,
                            "run each reduced model also in one frame for the whole run (its "
                            "rotations linearized), method reduced_<file stem>_one_frame, beside "
                            "its floating frame");
    validate_free->add_flag("--reduced-projected-torque", vfb->reduced_projected_torque,
                            "run each reduced model also with its projected forces' own torques (the "
                            "internal force's and the planes' as the basis projects them, which a basis "
                            "without the turned deformation leaks), method "
                            "reduced_<file stem>_projected_torque; by default the true torques");
    validate_free->add_option("--impact-speeds", vfb->impact_speeds,
                              "the impact study's speeds (m/s): the upright cat 1 mm above the "
                              "floor moving onto it, gravity off, 0.3 s (impact.csv)")
      ->capture_default_str()
      ->delimiter(',')
      ->check(CLI::Range(1e-4, 10.0));
    validate_free->add_option("--vdof-subdivisions", vfb->vdof_subdivisions,
                              "the virtual-DOF model's dome: 10 * 4^S + 2 orientations; -1: no "
                              "virtual-DOF method")
      ->capture_default_str()
      ->check(CLI::Range(-1, 4));
    validate_free->add_option("--vdof-length", vfb->vdof_length,
                              "samples per virtual-DOF response (T; the step is the scene's)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    add_reference_options(*validate_free, *vfb);
    validate_free->add_flag("--centrifugal", vfb->centrifugal,
                            "the modal routes take the spin's centrifugal force into the "
                            "deformation (the model's /modes/centrifugal_load); free flight "
                            "then runs with it as well");
    validate_free->add_flag("--deformed-inertia", vfb->deformed_inertia,
                            "the modal routes' rigid body takes the deformed body's inertia "
                            "(to first order in the deformation; the spin slows as the body "
                            "stretches); with --centrifugal, spin and stretch exchange energy "
                            "and create none; free flight then runs with it as well");
    validate_free->add_flag("--frame-forces", vfb->frame_forces,
                            "the modal routes take the moving frame's Euler, spin-softening and "
                            "Coriolis forces into the deformation (the model's "
                            "/modes/inertial_coupling; docs/free-body.md); with --centrifugal "
                            "and --deformed-inertia, the linear floating-frame theory");
    validate_free->add_flag("--deformation-momentum", vfb->deformation_momentum,
                            "the modal routes' rigid body takes the deformation's own angular "
                            "momentum and, with --deformed-inertia, the inertia's second-order "
                            "change (the model's /modes/inertial_coupling, on --frame-modes; "
                            "docs/free-body.md)");
    validate_free->add_option("--frame-modes", vfb->frame_modes,
                              "with --frame-forces or --deformation-momentum: the lowest modes they act on (9 N^2 "
                              "multiply-adds per step; default: every mode whose couplings the "
                              "model holds, irdm precompute --inertial-modes)");
    validate_free->add_flag("--reuse-models", vfb->reuse_models,
                            "take a virtual-DOF model already in --model-dir instead of "
                            "precomputing it (it must be of the same scene and material)");
    return {validate_free, [vfb, validate_free] {
               if (validate_free->count("--fem-divisions") == 0)
                 {
                   vfb->fem_divisions.clear();
                   for (const double E : vfb->materials)
                     vfb->fem_divisions.push_back(E < 1e4 ? 4 : 1);
                 }
               if (!vfb->converged_mesh.empty() && validate_free->count("--converged-degree") == 0)
                 vfb->converged_degree = 1;
               irdm::check_output_folder("--out", vfb->report_dir);
               vfb->plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_free.py";
               irdm::validation::run_free_body_validation(*vfb, std::cout);
               return 0;
             }};
  }
} // namespace irdm::cli
