#pragma once
// The free body against the nonlinear reference FEM (issue 14): the cat fixed to nothing,
// dropped on a floor upright from several heights, tilted, spinning, and thrown against a
// wall, for a soft material (the seeds') and a firmer gel. The runtime is FreeBodyInteraction
// (irdm/free_body.h): rigid-body dynamics and the modal deformation of the free-body model,
// by both routes (route 1, the seed's rigid fit; route 2, modal). Errors over time of the centre of mass, the orientation, the plane forces and the
// deformation in the body frame; cost per step of both methods in the same run. Writes
// reports/free/ (free.csv, series.csv, report.md).
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct FreeBodyValidationOptions
  {
    std::string         scene      = "validation/scenes/free/free_cat.json"; // the body
    std::string         report_dir = "reports";
    std::string         model_dir  = "out/models/free"; // one free model per material
    std::vector<double> materials  = {2000, 50000};     // Young's moduli, Pa
    double              duration   = 0.6;               // s per case
    // The truth's own step: the nonlinear FEM runs at tau / M, sampled at tau, one M for every
    // material or one per material. The soft material needs it: at 2 kPa and tau = 2 ms the
    // FEM's energy grows (average-acceleration Newmark on large strains), at 1 and 0.5 ms it
    // falls with the damping and the two agree (docs/scene-format.md, reports/free).
    std::vector<unsigned> fem_divisions = {4, 1};
    // Modes in the runtime's surface update; 0: every mode (the method's own error, with no
    // truncation of the surface). The impact study also runs route 2 with study_surface_modes
    // in its surface (method route2_modal_s<M>, 0: not run): what the truncation costs.
    unsigned            surface_modes = 0;
    unsigned            study_surface_modes = 100;
    // Each route also with this many modes in the force loop (the rest quasi-static): methods
    // route1_rigid_fit_k<K> and route2_modal_k<K>, the cheaper step. 0: not run.
    unsigned            force_modes = 300;
    double              stability_seconds = 60; // the runtime alone, rolling on the floor
    bool                quick = false; // the 5 cm drop and the tilt only
    std::vector<std::string> only_cases; // run just these cases (names as in free.csv)
    // Reduced nonlinear models of the free body (irdm precompute --reduced on its scene at a
    // material's Young's modulus), each a method reduced_<file stem> on that material's cases.
    std::vector<std::string> reduced_models;
    // Each reduced model also in one frame for the whole run (its rotations linearized; a
    // method reduced_<stem>_one_frame), beside the floating frame.
    bool reduced_one_frame = false;
    // Each reduced model also with its projected forces' own torques
    // (ReducedBodyOptions::keep_angular_momentum off; a method reduced_<stem>_projected_torque).
    bool reduced_projected_torque = false;
    // The seed's virtual DOFs of the free body (irdm precompute-vdof on it): icosahedron
    // subdivisions (2: 162 orientations), -1: not run; T samples per response.
    int      vdof_subdivisions = 2;
    unsigned vdof_length       = 100;
    bool     reuse_models      = false; // take a virtual-DOF model already in model_dir
    // Also run the FEM at half the time step and compare it with the FEM at tau by the same
    // measures: how well the truth itself is determined (truth.csv, a table in report.md).
    bool     truth_check = false;
    // Also run the linear FEM with the floor 1 um lower and compare it with the linear FEM by
    // the same measures (linearization.csv, fem_linear_body_frame_floor_1um): how far the
    // scene itself decides each figure, over the first contact and the whole run.
    bool     sensitivity = false;
    // The floor's shifts of the sensitivity runs (micrometres; one linear FEM run each, method
    // <linear FEM>_floor_<x>um).
    std::vector<double> sensitivity_um = {1};
    // Also run the FEM with a linear law and measure the linearization (it against the truth)
    // and the method (the runtime against it) apart (linearization.csv, a table in report.md).
    bool     small_strain = true;
    // That linear FEM's law: true, the small-strain law in the body's frame (material.law
    // "linear_body_frame", run `fem_linear_body_frame`: linear elasticity as a free body's IRDM
    // linearizes it); false, the plain small-strain law ("linear", run `fem_small_strain`),
    // which is not objective (a spin swells its body instead of turning it), so not run for a
    // case that starts spinning.
    bool     body_frame = true;
    // Also run the FEM with the corotational law (material.law "corotational", run
    // `fem_corotational`): against the truth, the share of a miss that is the strain's
    // (linear against nonlinear in the strain); the linear FEM against it, the rotation's
    // (linearized against each point's own rotation) (linearization.csv).
    bool     corotational = true;
    // The truth's own discretization error: on converged_cases (every material of the run),
    // the nonlinear FEM again with elements of this degree on the same mesh (0: not run), the
    // P1 truth against it, and every run against it (linearization.csv, reference
    // fem_neo_hookean_p<degree>).
    unsigned                 converged_degree = 2;
    std::vector<std::string> converged_cases  = {"drop_2cm"};
    // A finer mesh of the same body for that converged truth (empty: the same mesh): each
    // plane moved by the two bodies' difference in reach along its normal, as the grounded
    // family's walls are, and its surface read at the closest point to each of the body's
    // surface vertices (reference fem_neo_hookean_p<degree>_<mesh file stem>). Cases without a
    // probe (the probe's vertex is the coarse mesh's).
    std::string              converged_mesh;
    // Coarser meshes of the same body than converged_mesh (or any others), each one's truth
    // run as the converged truth is and scored against it (linearization.csv, method
    // fem_neo_hookean_p<degree>_<mesh> against the converged truth): whether that truth is
    // converged, measured rather than assumed. Needs converged_mesh.
    std::vector<std::string> converged_check_meshes;
    // The modal routes take the spin's centrifugal force into the deformation
    // (FreeBodyOptions::centrifugal); false: left out, as the virtual DOFs leave it. Off by
    // default: on the cat's roll it changed no figure at 50 kPa and made 2 kPa worse (README.md)
    // and its strain energy is not taken from the spin (free flight then gains energy).
    bool     centrifugal = false;
    // The modal routes' rigid body takes the deformed body's inertia (FreeBodyOptions::
    // deformed_inertia): with `centrifugal`, spin and stretch exchange energy and create none.
    bool     deformed_inertia = false;
    // The modal routes take the moving frame's other forces on the deformation too: the Euler
    // force, the spin softening and the Coriolis force (FreeBodyOptions::euler, ...; the
    // models' /modes/inertial_coupling; docs/free-body.md).
    bool     frame_forces = false;
    // The modal routes' rigid body takes the deformation's own angular momentum and the
    // inertia's second-order change (FreeBodyOptions::deformation_momentum).
    bool     deformation_momentum = false;
    unsigned frame_modes  = 0; // the lowest modes they act on (0: every one the model holds)
    // The impact study: the upright cat moving at these speeds (m/s) onto the floor, gravity
    // off (impact.csv). Runs in a full run, or with only_cases holding "impact"; empty: not run.
    // The last two are the impact speeds of the 2 and 5 cm drops, sqrt(2 g h).
    std::vector<double> impact_speeds = {0.05, 0.1, 0.2, 0.4, 0.626, 0.99};
    std::string         plot_script = "validation/plot_free.py"; // empty: no charts
  };

  void
  run_free_body_validation(const FreeBodyValidationOptions &options, std::ostream &log);
} // namespace irdm::validation
