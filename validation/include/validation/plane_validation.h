#pragma once
// Surface contact against the nonlinear reference FEM: rigid walls pressing the grounded cat
// from the side, the top, between the dome's directions and from two sides at once at
// increasing depths, turning on the side so that the contact patch slides, and hitting it
// from the side at increasing speeds; rigid and compliant walls; by virtual DOFs
// (seed 001, nearest and interpolated orientation mapping) and by many-vertex contact (modal
// and direct model). Errors of the wall force, impulse and surface displacement, time per step
// of every method (same run). Writes reports/planes/.
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct PlaneValidationOptions
  {
    std::string scene       = "validation/scenes/press.json"; // the body (probes ignored)
    std::string report_dir  = "reports";
    std::string model_file  = "out/models/cat_vdof.h5"; // reused if it exists with this spec
    unsigned    subdivisions = 2;   // 162 orientations
    // T, samples: 300 x 2 ms covers the longest case (0.6 s), so no force leaves the history
    // window during the comparison (no truncation error in it).
    unsigned    length       = 300;
    // Many-vertex contact (issue 13): its model (every free surface vertex in and out, reused
    // if it exists for this scene), the candidate margin and capacity, the modes of the
    // surface update, and whether to run the direct model too (its H takes GBs).
    std::string vertex_model_file = "out/models/cat_vertex.h5";
    double      margin            = 0.005; // m
    unsigned    max_candidates    = 512;
    unsigned    surface_modes     = 100;
    bool        direct            = true;
    // Vertex contact's walls in the main table: N/m per vertex; < 0: the FEM penalty's
    // per-vertex equivalent (the truth's own wall compliance); 0: rigid.
    double      vertex_stiffness  = -1;
    // Compliant walls: these stiffnesses (N/m, per vertex and per virtual DOF) on the cases
    // named (0: rigid); the vertex sweep adds the FEM penalty's per-vertex
    // equivalent (penalty x mean vertex area).
    std::vector<double>      stiffness_sweep = {0, 10, 30, 100, 300, 1000, 3000, 10000, 100000};
    std::vector<std::string> sweep_cases     = {"press_side_5mm", "press_top_5mm",
                                                "impact_side_100mm_s", "slide_side_5mm"};
    // Each method's run again this many times with the walls' penetration, their speed or
    // their stiffness scaled by 1 + eps, eps = +-1e-6 or +-1e-3 (plane_runs.cc): the range
    // of each error is reported beside it.
    unsigned    perturbations = 12;
    // Also run the FEM with the corotational law and with the small-strain law (the truth's
    // own contact) on every case: the first against the truth is the strain's share of a
    // linear model's miss, the second against the first the rotation's (cases.csv).
    bool        corotational = true;
    // The truth's own discretization error: on converged_cases, the nonlinear FEM again with
    // elements of this degree (0: not run) on the same mesh, or on converged_mesh (a finer
    // gmsh mesh of the same body with the same physical surfaces; each wall's depth from its
    // own outermost point, its surface displacement taken at this mesh's surface vertices), and
    // every method scored against it beside the P1 truth (converged.csv).
    unsigned                 converged_degree = 2;
    std::string              converged_mesh;
    std::vector<std::string> converged_cases  = {"press_top_5mm", "press_side_10mm"};
    // Reduced nonlinear models (irdm precompute --reduced) of this scene's body, each run on
    // every case beside the other methods as the method reduced_<its file's stem>.
    std::vector<std::string> reduced_models;
    // Their Newton stop: the residual within this fraction of its largest force
    // (ReducedBodyOptions::tolerance).
    double reduced_newton_tolerance = 1e-8;
    // Only these cases (each a case name, such as press_top_5mm, or a kind, such as
    // press_top_and_side or slide_side); empty: every case of the run.
    std::vector<std::string> cases;
    std::string plot_script;        // python script for the charts; "" skips charts
    // Fewer depths and speeds (every kind of case and the sweep's cases kept): the main job's
    // default, within its 10-minute budget.
    bool quick = false;
  };

  void
  run_plane_validation(const PlaneValidationOptions &options, std::ostream &log);
} // namespace irdm::validation
