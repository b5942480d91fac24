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

TEST(Planes, RigidWallIsMetExactlyAndNeverPulls)
{
  const fem::Scene s = fem::parse_scene(irdm_test::beam_scene(""), ".");
  fem::VirtualDofOptions o;
  o.output       = irdm_test::tmp("beam_vdof.h5");
  o.subdivisions = 0;
  o.length       = 20;
  o.impulse_depth = 5e-4;
  fem::precompute_virtual_dofs(s, o);
  const VirtualDofModel m = load_virtual_dof_model(o.output, s.time_step);
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
  for (const auto &x : m.coordinates)
    support = std::max(support, d[0] * x[0] + d[1] * x[1] + d[2] * x[2]);
  PlaneInteraction run(m, OrientationMapping::interpolated);
  unsigned         touching = 0;
  for (unsigned n = 0; n < 40; ++n)
    {
      // In by 1 mm over 10 steps, held, then away.
      const double p = n < 10 ? 1e-4 * n : n < 25 ? 1e-3 : -1e-3;
      const double F = run.step(d, support - p);
      EXPECT_GE(F, 0);
      const double surface_at = support - run.virtual_dof_displacement();
      if (F > 0)
        {
          ++touching;
          EXPECT_NEAR(surface_at, support - p, 1e-12) << "step " << n; // rigid: met exactly
        }
      else
        EXPECT_LE(surface_at, support - p + 1e-12) << "step " << n; // apart, or just touching
    }
  EXPECT_GT(touching, 10u);
}
