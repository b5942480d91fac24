// Virtual-DOF plane contact: the geodesic dome, the orientation mapping, and the runtime's
// rigid-wall solve on a small precomputed model (the wall is met exactly, never pulls).
#include <irdm/plane_interaction.h>
#include <reference_fem/scene.h>
#include <reference_fem/virtual_dof.h>

#include <gtest/gtest.h>

#include <cmath>

#include "irdm_test_util.h"

using namespace irdm;

TEST(Planes, GeodesicDomeHas162UnitDirectionsWithOneAtTheTop)
{
  const auto d = fem::geodesic_dome(2);
  ASSERT_EQ(d.directions.size(), 162u);
  EXPECT_EQ(d.triangles.size(), 320u);
  for (const auto &x : d.directions)
    EXPECT_NEAR(x[0] * x[0] + x[1] * x[1] + x[2] * x[2], 1, 1e-14);
  EXPECT_EQ(d.directions[0], (fem::Vec3{0, 0, 1}));
  EXPECT_EQ(fem::geodesic_dome(0).directions.size(), 12u);
}

namespace
{
  // The test beam's virtual-DOF model: 12 orientations (no subdivision), impulse 0.5 mm deep.
  const double beam_impulse_depth = 5e-4;

  VirtualDofModel
  beam_vdof_model(const std::string &file, const unsigned length)
  {
    const fem::Scene       s = fem::parse_scene(irdm_test::beam_scene(""), ".");
    fem::VirtualDofOptions o;
    o.output        = irdm_test::tmp(file);
    o.subdivisions  = 0;
    o.length        = length;
    o.impulse_depth = beam_impulse_depth;
    fem::precompute_virtual_dofs(s, o);
    return load_virtual_dof_model(o.output, s.time_step);
  }
} // namespace

TEST(Planes, RigidWallIsMetExactlyAndNeverPulls)
{
  const VirtualDofModel m = beam_vdof_model("beam_vdof.h5", 20);
  ASSERT_EQ(m.n_orientations, 12u);
  // A direction between dome vertices: interpolation weights reproduce it.
  const std::array<double, 3> d = {0.6, 0.0, 0.8};
  const auto w = orientation_weights(m, d, OrientationMapping::interpolated);
  ASSERT_EQ(w.n, 3u);
  EXPECT_NEAR(w.w[0] + w.w[1] + w.w[2], 1, 1e-14);
  // At a dome direction, interpolation is the nearest DOF.
  const auto at = orientation_weights(m, m.directions[3], OrientationMapping::interpolated);
  double     w3 = 0;
  for (unsigned i = 0; i < at.n; ++i)
    if (at.k[i] == 3)
      w3 = at.w[i];
  EXPECT_NEAR(w3, 1, 1e-12);

  double support = -1e300;
  for (unsigned i = 0; i < m.n_surface; ++i)
    if (!m.fixed[i])
      support = std::max(support, d[0] * m.coordinates[i][0] + d[1] * m.coordinates[i][1] +
                                    d[2] * m.coordinates[i][2]);
  PlaneInteraction run(m, OrientationMapping::interpolated);
  unsigned         touching = 0;
  for (unsigned n = 0; n < 40; ++n)
    {
      // In by 1 mm over 10 steps, held, then away.
      const double p = n < 10 ? 1e-4 * n : n < 25 ? 1e-3 : -1e-3;
      const double F = run.step(d, support - p);
      EXPECT_GE(F, 0);
      // The band, where the wall holds it; it rests below the support.
      const double surface_at = run.rest_position() - run.virtual_dof_displacement();
      EXPECT_LE(run.rest_position(), support);
      if (F > 0)
        {
          ++touching;
          EXPECT_NEAR(surface_at, support - p, 1e-12) << "step " << n; // rigid: met exactly
        }
      else
        EXPECT_LE(surface_at, support - p + 1e-12) << "step " << n; // apart, or just touching
    }
  // The wall pushes on several steps of the ramp (it also bounces off: y overshoots the wall
  // between pushes, which the checks above allow).
  EXPECT_GT(touching, 3u);
}

TEST(Planes, RuntimeReproducesThePrecomputedImpulse)
{
  // The runtime's wall, moved as the precompute's was (at first_contact_k - depth for one
  // step, then away), must give back the precompute's force F_k and surface response: the
  // discrete definition of the impulse and the runtime agree. What remains is the FEM
  // penalty wall's penetration (it is not quite rigid), a small fraction of the depth.
  const VirtualDofModel m = beam_vdof_model("beam_vdof_impulse.h5", 12);
  double worst = 0;
  for (unsigned k = 0; k < m.n_orientations; ++k)
    {
      PlaneInteraction run(m, OrientationMapping::nearest);
      const double     F = run.step(m.directions[k], m.first_contact[k] - beam_impulse_depth);
      worst              = std::max(worst, std::abs(F / m.impulse_force[k] - 1));
      EXPECT_NEAR(F, m.impulse_force[k], 0.025 * m.impulse_force[k]) << "orientation " << k;
      for (unsigned n = 1; n < m.length; ++n)
        EXPECT_EQ(run.step(m.directions[k], m.first_contact[k] + 1), 0.0); // away: no pull
      // The surface after the impulse is the precompute's, scaled by F / F_k.
      const auto &u = run.update_surface();
      const float *S = &m.surface_response[(static_cast<size_t>(k) * m.length + m.length - 1) *
                                           3 * m.n_surface];
      for (unsigned i = 0; i < 3 * m.n_surface; ++i)
        EXPECT_NEAR(u[i], S[i] * F, 1e-6 * std::abs(F) + 1e-15);
    }
  std::printf("runtime impulse vs precompute: worst |F / F_k - 1| = %.3g\n", worst);
}
