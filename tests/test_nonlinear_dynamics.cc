// Nonlinear dynamics with rigid-plane contact: at small amplitude the linear solver's history
// (difference first order in the load); a free elastic ball bouncing on a floor keeps its
// energy, its momentum changes by exactly the floor's impulse, and its peak force is Hertz's.
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <validation/fem_verification.h>

using namespace irdm::fem;
using irdm::validation::BeamModel;
using irdm::validation::beam_scene_json;

namespace
{
  // A clamped beam pushed at its tip for 10 ms, then free, 25 steps of generalized-alpha.
  Scene
  pulsed_beam(const double fz)
  {
    return parse_scene(
      beam_scene_json(IRDM_MESH_DIR "/beam_2.msh", 1, BeamModel(),
                      R"(, "kinematics": "nonlinear",
       "damping": {"ratios": [0.02, 0.02], "frequencies_Hz": [1, 50]},
       "integrator": {"type": "generalized_alpha", "rho_inf": 0.8},
       "time": {"step_s": 0.002, "duration_s": 0.05},
       "loads": [{"type": "surface_force", "surface": "tip", "total_force_N": [0, 0, )" +
                        std::to_string(fz) + R"(],
                  "history": {"times_s": [0, 0.01, 0.012], "factors": [1, 1, 0]}}],
       "outputs": {"vertices": [{"name": "tip", "vertex": {"nearest_to_m": [0.25, 0.005, 0.005]}}]})"),
      ".");
  }

  // An elastic ball (radius 5 cm, 2e4 Pa) moving down at speed v, 0.1 mm above a floor;
  // no gravity, no damping, Newmark (which conserves the energy of the linear part).
  Scene
  ball(const std::string &mesh, const double v, const double dt, const double duration,
       const double penalty = 0)
  {
    char planes[256];
    std::snprintf(planes, sizeof planes,
                  R"([{"name": "floor", "normal": [0, 0, 1], "position": {"times_s": [0], "points_m": [[0, 0, -1e-4]]}%s}])",
                  penalty > 0 ? (", \"penalty_Pa_m\": " + std::to_string(penalty)).c_str() : "");
    char json[1024];
    std::snprintf(json, sizeof json,
                  R"({"format": "irdm-scene/1", "name": "ball", "mesh": {"file": "%s"}, "fe_degree": 1,
      "material": {"youngs_modulus_Pa": 20000, "poisson_ratio": 0.4, "density_kg_m3": 1100},
      "integrator": {"type": "newmark"}, "time": {"step_s": %.17g, "duration_s": %.17g},
      "kinematics": "nonlinear", "initial_velocity_m_s": [0, 0, %.17g], "planes": %s})",
                  mesh.c_str(), dt, duration, -v, planes);
    return parse_scene(json, ".");
  }

  double
  total_energy(const RunResult &r, const std::size_t k)
  {
    return r.kinetic_energy[k] + r.strain_energy[k] + r.contact_energy[k] + r.gravity_energy[k];
  }
} // namespace

TEST(NonlinearDynamics, SmallAmplitudeAgreesWithTheLinearSolver)
{
  const auto tip_history = [](const RunResult &r) {
    std::vector<double> z;
    for (const auto &u : r.vertex_displacement.at("tip"))
      z.push_back(u[2]);
    return z;
  };
  const double F = -1e-4; // N: bends the tip by about 5 % of the length, linear theory
  const auto linear = tip_history(ElasticDynamics(pulsed_beam(F)).run());
  double peak = 0;
  for (const double z : linear)
    peak = std::max(peak, std::abs(z));
  std::vector<double> diff;
  for (const double scale : {0.01, 0.1})
    {
      const auto nonlinear = tip_history(NonlinearElasticity(pulsed_beam(scale * F)).run());
      ASSERT_EQ(nonlinear.size(), linear.size());
      double d = 0;
      for (std::size_t k = 0; k < linear.size(); ++k)
        d = std::max(d, std::abs(nonlinear[k] / scale - linear[k]));
      diff.push_back(d / peak);
    }
  std::printf("dynamic small-amplitude difference from the linear solver (max over the history"
              " / peak): %.3g at 1e-6 N, %.3g at 1e-5 N\n", diff[0], diff[1]);
  EXPECT_LT(diff[0], 1e-3);
  EXPECT_NEAR(diff[1] / diff[0], 10, 1.5); // first order in the load
}

TEST(NonlinearDynamics, BouncingBallKeepsEnergyAndTakesTheFloorsImpulse)
{
  const double v = 0.1, dt = 0.002;
  const Scene  s = ball(IRDM_MESH_DIR "/ball.msh", v, dt, 0.14);
  const auto   r = NonlinearElasticity(s).run();
  const auto  &F = r.plane_force.at("floor");
  const auto  &p = r.linear_momentum;
  const double m = p[0][2] / -v; // kg, from the initial momentum
  double       peak = 0, impulse = 0, drift = 0;
  for (std::size_t k = 0; k < F.size(); ++k)
    {
      peak = std::max(peak, F[k][2]);
      drift = std::max(drift, std::abs(total_energy(r, k) / total_energy(r, 0) - 1));
      if (k > 0)
        impulse += 0.5 * dt * (F[k - 1][2] + F[k][2]); // Newmark's momentum balance
    }
  const double v_end = p.back()[2] / m;
  std::printf("ball at %.2g m/s: peak floor force %.4g N, energy drift %.2e, rebound %.4g m/s, "
              "momentum change %.6g, floor impulse %.6g N s; Newton %u iterations, %u "
              "factorizations\n", v, peak, drift, v_end, p.back()[2] - p[0][2], impulse,
              r.newton_iterations, r.tangent_factorizations);
  EXPECT_GT(peak, 0);
  EXPECT_LT(F.back()[2], 1e-12) << "the ball has left the floor";
  // Internal forces cancel: the momentum changes by exactly the floor's (trapezoidal) impulse.
  EXPECT_NEAR(p.back()[2] - p[0][2], impulse, 1e-6 * m * v);
  // Frictionless, undamped, Newmark: the energy is kept (the tolerance covers the penalty's
  // contact kinks and Newton's tolerance).
  EXPECT_LT(drift, 5e-3);
  // It bounces back with most of its speed; the rest stays as vibration energy.
  EXPECT_GT(v_end, 0.8 * v);
  EXPECT_LE(v_end, v * (1 + 1e-3));
}

TEST(NonlinearDynamics, BallPeakForceFollowsHertzAtLowSpeed)
{
  // Hertz, sphere on a rigid plane: E* = E / (1 - nu^2), delta_max = (15 m v^2 / (16 E* sqrt R))^(2/5),
  // F_max = 4/3 E* sqrt(R) delta_max^(3/2). At 2 cm/s, delta_max / R = 2 %.
  const double v = 0.02, R = 0.05, E = 20000, nu = 0.4, rho = 1100;
  const double m   = rho * 4.0 / 3.0 * M_PI * R * R * R, Es = E / (1 - nu * nu);
  const double dm  = std::pow(15 * m * v * v / (16 * Es * std::sqrt(R)), 0.4);
  const double F_h = 4.0 / 3.0 * Es * std::sqrt(R) * std::pow(dm, 1.5);
  const auto   r   = NonlinearElasticity(ball(IRDM_MESH_DIR "/ball_pole_4.msh", v, 0.004, 0.1)).run();
  double       peak = 0;
  for (const auto &f : r.plane_force.at("floor"))
    peak = std::max(peak, f[2]);
  std::printf("Hertz at %.2g m/s: FEM peak %.4g N, theory %.4g N (%+.1f %%)\n", v, peak, F_h,
              100 * (peak / F_h - 1));
  EXPECT_NEAR(peak / F_h, 1, 0.15); // coarse pole mesh (4 mm); the report's study refines it
}
