#pragma once
// The reference-FEM verification suite: each check compares the FEM with theory (beam theory,
// exact energy conservation, equilibrium, prescribed damping, reaction consistency) and is
// written to a Markdown report with CSV series.
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct FemVerificationOptions
  {
    std::string mesh_dir   = "meshes";
    std::string report_dir = "reports/fem-verification";
    bool        quick      = false; // skip the finest beam mesh
  };

  struct CheckResult
  {
    std::string name;
    std::string measured;  // what was measured, with units
    std::string criterion; // what it had to reach
    bool        pass = false;
  };

  // Individual checks (also used by the unit tests on small meshes).
  struct BeamModel
  {
    double length = 0.25, side = 0.01; // m, matches meshes/beam.geo
    double youngs_modulus = 2.0e5, poisson_ratio = 0.4, density = 1100;
    double euler_bernoulli_frequency() const; // Hz, first bending mode, clamped-free
    double tip_deflection(double force) const; // m, F L^3 / (3 E I)
  };

  /// Scene JSON for the cantilever on mesh_file (fixed "clamp"), without loads.
  std::string
  beam_scene_json(const std::string &mesh_file, unsigned degree, const BeamModel &beam,
                  const std::string &extra_keys = "");

  /// Runs every check, writes the report, prints a summary; true if all pass.
  bool
  run_fem_verification(const FemVerificationOptions &options, std::ostream &log);
} // namespace irdm::validation
