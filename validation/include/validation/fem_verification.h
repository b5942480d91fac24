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

  /// Hertz: an elastic sphere (radius R) hitting a rigid frictionless plane at speed v, in
  /// the quasi-static small-strain limit (K. L. Johnson, Contact Mechanics, 1985, sec. 11.4).
  /// The defaults match meshes/ball_pole.geo and the soft material of the tests.
  struct HertzBall
  {
    double radius = 0.05, youngs_modulus = 2.0e4, poisson_ratio = 0.4, density = 1100;
    double body_mass = 0;                   // kg; 0: the exact sphere's, 4/3 pi R^3 rho
    double mass() const;                    // kg
    double effective_modulus() const;       // Pa, E / (1 - nu^2) against a rigid plane
    double contact_stiffness() const;       // N/m^(3/2), k = 4/3 E* sqrt(R): F = k delta^(3/2)
    double max_indentation(double v) const; // m, (15 m v^2 / (16 E* sqrt R))^(2/5)
    double peak_force(double v) const;      // N, k delta_max^(3/2)
    double contact_time(double v) const;    // s, 2.87 (m^2 / (R E*^2 v))^(1/5)
    double contact_radius(double v) const;  // m, sqrt(R delta_max)

    /// An estimate beyond Hertz, for a ball of finite size. Hertz's impact theory lets the
    /// ball's centre approach the plane like a distant point of a half-space; the centre of
    /// a ball lies at depth R, where a half-space under the contact force F has moved
    /// F (3 - 2 nu) / (4 pi mu R) along the axis (Boussinesq). With that compliance c the
    /// centre approaches by delta_Hertz(F) - c F, and the energy balance
    /// 1/2 m v^2 = 2/5 k^(-2/3) F^(5/3) - c F^2 / 2 (k = 4/3 E* sqrt R) gives the peak force,
    /// above Hertz's by about 0.58 a / R at nu = 0.4. The free surface and the decelerating
    /// body force of a real ball change the constant: this explains a trend, it is no theory.
    double centre_compliance() const;          // m/N, (3 - 2 nu) / (4 pi mu R)
    double peak_force_finite_ball(double v) const; // N
  };

  /// Scene JSON: the ball on mesh_file (P1, nonlinear, no gravity, no damping, Newmark)
  /// moving down at speed v (m/s) 0.1 mm above a floor at z = -1e-4 m with the given penalty
  /// (Pa/m; 0: the default 100 E / h).
  std::string
  ball_scene_json(const std::string &mesh_file, const HertzBall &ball, double speed,
                  double time_step, double duration, double penalty = 0);

  /// Runs every check, writes the report, prints a summary; true if all pass.
  bool
  run_fem_verification(const FemVerificationOptions &options, std::ostream &log);
} // namespace irdm::validation
