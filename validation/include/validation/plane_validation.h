#pragma once
// Surface contact by virtual DOFs (seed 001) against the nonlinear reference FEM: a rigid wall
// pressing the grounded cat from the side and from the top at increasing depths, and hitting
// it from the side at increasing speeds. Errors of the wall force and of the surface
// displacement, time per step of both methods (same run), and nearest against interpolated
// orientation mapping. Writes reports/planes/.
#include <ostream>
#include <string>

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
    std::string plot_script;        // python script for the charts; "" skips charts
  };

  void
  run_plane_validation(const PlaneValidationOptions &options, std::ostream &log);
} // namespace irdm::validation
