#pragma once
// The validation scenes on a converged discretization (issue 16): each probe scene of
// validation/scenes/ with a probe of contact radius r (a force that converges with the mesh),
// run on the scene's own discretization (the coarse P1 cat every other report uses) and on a
// converged one (a finer mesh or degree, within 5 % of the extrapolated driving-point
// stiffness, reports/convergence/). Two errors are reported apart:
// - method error: IRDM against the FEM of the same discretization (the coarse model has every
//   mode and is exact; the converged one keeps the lowest modes plus residual modes, the
//   sparse route);
// - discretization error: a discretization's FEM, and its IRDM model, against the converged
//   FEM.
// Writes reports/converged/ (converged.csv, report.md).
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct ConvergedValidationOptions
  {
    std::string              scenes_dir = "validation/scenes";
    std::vector<std::string> scenes = {"press", "tap", "tap_coupled", "squeeze", "trace"};
    std::string              converged_mesh;        // gmsh file; required
    unsigned                 converged_degree = 1;  // FE degree on it
    double                   probe_radius     = 0.02; // m, the probes' contact radius
    // The extrapolated (mesh-converged) driving-point stiffness of the first probe of scene
    // `extrapolated_scene` with this radius, N/m (reports/convergence/: the press probe); 0:
    // not known. Compared with the scenes whose first probe starts at the same point along
    // the same direction (press, tap, tap_coupled); the others have no percentage.
    double                   extrapolated_stiffness = 0;
    std::string              extrapolated_scene     = "press";
    unsigned                 modes = 200; // lowest modes of the converged model (sparse route)
    std::string              report_dir = "reports";
    std::string              model_dir  = "out/models/converged"; // working models, removed after use
  };

  void
  run_converged_validation(const ConvergedValidationOptions &options, std::ostream &log);
} // namespace irdm::validation
