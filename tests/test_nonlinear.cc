// Geometrically nonlinear reference FEM (Total Lagrangian neo-Hookean): the tangent is the
// derivative of the residual; at small load it is the linear solver (difference proportional
// to the load); hyperelastic statics do not depend on the load path.
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include <validation/fem_verification.h>

using namespace irdm::fem;
using irdm::validation::BeamModel;
using irdm::validation::beam_scene_json;

namespace
{
  const std::string beam2 = IRDM_MESH_DIR "/beam_2.msh";
  const std::string tip_output =
    R"("outputs": {"vertices": [{"name": "tip", "vertex": {"nearest_to_m": [0.25, 0.005, 0.005]}}]})";

  Scene
  loaded_beam(const double fz)
  {
    return parse_scene(beam_scene_json(beam2, 1, BeamModel(),
                                       R"(, "time": {"step_s": 1, "duration_s": 1},
       "loads": [{"type": "surface_force", "surface": "tip", "total_force_N": [0, 0, )" +
                                         std::to_string(fz) + "]}], " + tip_output),
                       ".");
  }
} // namespace

// Both objective laws: neo-Hookean and the corotational small-strain law (whose tangent
// carries the derivative of each point's polar rotation).
TEST(Nonlinear, TangentIsTheDerivativeOfTheResidual)
{
  for (const bool corotational : {false, true})
    {
      Scene s            = loaded_beam(-1e-4);
      s.corotational_law = corotational;
      const NonlinearElasticity nl(s);
      for (const double amplitude : {1e-3, 0.03, 0.3})
        {
          const double e1 = nl.tangent_check(amplitude, 1e-4);
          const double e2 = nl.tangent_check(amplitude, 1e-5);
          std::printf("%s, amplitude %g: tangent against central differences %.2e, %.2e\n",
                      corotational ? "corotational" : "neo-Hookean", amplitude, e1, e2);
          // Central differences converge to the tangent at second order in the step, down to
          // round-off; a wrong tangent leaves an error that does not shrink with the step.
          EXPECT_TRUE(e2 < 1e-7 || e1 / e2 > 50)
            << (corotational ? "corotational" : "neo-Hookean") << ", amplitude " << amplitude
            << ": " << e1 << ", " << e2;
          EXPECT_LT(e2, e1) << "central differences converge to the tangent";
        }
    }
}

TEST(Nonlinear, SmallLoadAgreesWithTheLinearSolver)
{
  const Scene           s = loaded_beam(-1e-4);
  const double          linear_tip = ElasticDynamics(s).solve_static(0).vertex_displacement.at("tip")[0][2];
  const NonlinearElasticity nl(s);
  std::vector<double>   diff;
  for (const double scale : {0.01, 0.1})
    {
      const double tip = nl.solve_static(0, scale).vertex_displacement.at("tip")[0][2];
      diff.push_back(std::abs(tip / scale - linear_tip) / std::abs(linear_tip));
    }
  std::printf("small-load difference from the linear solver: %.3g at 1e-6 N, %.3g at 1e-5 N\n",
              diff[0], diff[1]);
  EXPECT_LT(diff[0], 1e-3);
  // Geometric nonlinearity enters at first order in the load: ten times the load, ten times
  // the difference.
  EXPECT_NEAR(diff[1] / diff[0], 10, 1.5);
}

TEST(Nonlinear, LargeDeflectionDoesNotDependOnTheLoadPath)
{
  // A tip load that bends the beam well past the linear range.
  const Scene               s = loaded_beam(-1e-4);
  const NonlinearElasticity nl(s);
  const double linear_tip = ElasticDynamics(s).solve_static(0).vertex_displacement.at("tip")[0][2];
  NewtonReport a, b;
  const double scale = 0.2 * 0.25 / std::abs(linear_tip); // linear theory: 20 % of the length
  const auto   one   = nl.solve_static(0, scale, 4, &a).vertex_displacement.at("tip")[0];
  const auto   many  = nl.solve_static(0, scale, 16, &b).vertex_displacement.at("tip")[0];
  for (int d = 0; d < 3; ++d)
    EXPECT_NEAR(one[d], many[d], 1e-9 * 0.25);
  EXPECT_LT(std::abs(one[2]), 0.2 * 0.25 * 0.99); // stiffer than linear: it shortens its arm
  EXPECT_GT(std::abs(one[0]), 1e-4);              // and the tip moves back along the beam
  EXPECT_LT(a.residual, 1e-8); // Newton stops at 1e-10 or when its step is 1e-10 of u
}
