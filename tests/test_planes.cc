// Virtual-DOF plane contact: the geodesic dome, the orientation mapping, and the runtime's
// rigid-wall solve on a small precomputed model (the wall is met exactly, never pulls).
#include <irdm/plane_interaction.h>
#include <irdm/rigid_body.h>
#include <irdm/vertex_contact.h>
#include <irdm_common/complementarity.h>
#include <reference_fem/scene.h>
#include <reference_fem/virtual_dof.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "irdm_test_util.h"
#include "vertex_contact_step.h" // irdm/src: the contact step the runtimes share

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

TEST(Planes, SameContactMappingBlendsOnlyWhereTheWallTouches)
{
  // interpolated_same_contact keeps, of the interpolation's virtual DOFs, exactly those whose
  // first-contact vertex the wall along d reaches within the band, with weights renormalized.
  const VirtualDofModel m = beam_vdof_model("beam_vdof_map.h5", 5);
  const auto along = [&](const std::array<double, 3> &d, const std::array<double, 3> &x) {
    return d[0] * x[0] + d[1] * x[1] + d[2] * x[2];
  };
  const auto first_contact = [&](const std::array<double, 3> &d) {
    unsigned best = 0;
    for (unsigned i = 0; i < m.n_surface; ++i)
      if (!m.fixed[i] && (m.fixed[best] || along(d, m.coordinates[i]) > along(d, m.coordinates[best])))
        best = i;
    return m.coordinates[best];
  };
  unsigned dropped = 0, blended = 0;
  for (int a = 0; a < 24; ++a)
    for (int b = 1; b < 12; ++b)
      {
        const double th = M_PI * b / 12, ph = 2 * M_PI * a / 24;
        const std::array<double, 3> d = {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
        const auto all  = orientation_weights(m, d, OrientationMapping::interpolated);
        const auto same = orientation_weights(m, d, OrientationMapping::interpolated_same_contact);
        const double support = along(d, first_contact(d));
        double       sum_all = 0, sum_same = 0;
        for (unsigned i = 0; i < all.n; ++i)
          {
            if (!(all.w[i] > 0))
              continue;
            const bool touches = along(d, first_contact(m.directions[all.k[i]])) >= support - m.band;
            const auto kept    = std::find(same.k.begin(), same.k.begin() + same.n, all.k[i]);
            if (touches)
              {
                ASSERT_NE(kept, same.k.begin() + same.n);
                sum_all += all.w[i];
              }
            else
              {
                EXPECT_EQ(kept, same.k.begin() + same.n);
                ++dropped;
              }
          }
        ASSERT_GE(same.n, 1u);
        for (unsigned i = 0; i < same.n; ++i)
          sum_same += same.w[i];
        EXPECT_NEAR(sum_same, 1, 1e-14);
        if (sum_all > 0) // the kept weights keep their ratios
          for (unsigned i = 0; i < same.n; ++i)
            for (unsigned j = 0; j < all.n; ++j)
              {
                if (all.k[j] == same.k[i])
                  {
                    EXPECT_NEAR(same.w[i], all.w[j] / sum_all, 1e-14);
                  }
              }
        blended += same.n > 1;
      }
  std::printf("same-contact mapping over 264 directions: %u virtual DOFs dropped, %u blends kept\n",
              dropped, blended);
  EXPECT_GT(dropped, 0u);
  EXPECT_GT(blended, 0u);
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

// The many-vertex contact solve (irdm_common/complementarity.h) on random problems: the result
// satisfies the complementarity conditions to round-off, is unique (the same from any first
// guess), and a warm start from the answer takes one round.
namespace
{
  /// A random linear complementarity problem of n rows: W = A A^T / n + shift I (symmetric
  /// positive definite, dense, off-diagonals of both signs; row-major) and q, entries of A and
  /// q uniform in [-1, 1) from a fixed seed.
  void
  random_problem(const int n, const double shift, unsigned long long seed, std::vector<double> &W,
                 std::vector<double> &q)
  {
    const auto uniform = [&] {
      seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<double>(seed >> 11) / 4503599627370496.0 - 1;
    };
    std::vector<double> A(n * n);
    W.assign(n * n, 0.0);
    q.resize(n);
    for (auto &a : A)
      a = uniform();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        {
          for (int k = 0; k < n; ++k)
            W[i * n + j] += A[i * n + k] * A[j * n + k] / n;
          W[i * n + j] += i == j ? shift : 0;
        }
    for (auto &x : q)
      x = uniform();
  }
} // namespace

TEST(Planes, ComplementaritySolverMeetsTheConditionsExactly)
{
  for (const int n : {1, 7, 40, 150})
    {
      std::vector<double> W, q;
      random_problem(n, 0.01, 12345 + n, W, q);
      contact::ComplementaritySolver solver(n);
      std::vector<double>            lambda(n), first(n);
      std::vector<char>              active(n, 0);
      const int rounds = solver.solve(n, W.data(), n, q.data(), active.data(), lambda.data());
      ASSERT_GT(rounds, 0) << n;
      double scale = 0;
      int    n_active = 0;
      for (int i = 0; i < n; ++i)
        {
          scale = std::max(scale, std::abs(q[i]));
          n_active += active[i];
        }
      for (int i = 0; i < n; ++i)
        {
          double g = q[i];
          for (int j = 0; j < n; ++j)
            g += W[i * n + j] * lambda[j];
          EXPECT_GE(lambda[i], 0);
          EXPECT_GE(g, -1e-12 * scale);
          EXPECT_LE(std::abs(lambda[i] * g), 1e-12 * scale * std::max(1.0, lambda[i]));
          EXPECT_NEAR(g, solver.g(i), 1e-12 * scale);
        }
      if (n > 1)
        {
          EXPECT_GT(n_active, 0) << "a test with no contact at all tests little";
          EXPECT_LT(n_active, n) << "nor one where every row is in contact";
        }
      first = lambda;
      // From every row active: the same answer.
      std::fill(active.begin(), active.end(), 1);
      ASSERT_GT(solver.solve(n, W.data(), n, q.data(), active.data(), lambda.data()), 0);
      for (int i = 0; i < n; ++i)
        EXPECT_NEAR(lambda[i], first[i], 1e-10 * (1 + std::abs(first[i])));
      // Warm: one round.
      EXPECT_EQ(solver.solve(n, W.data(), n, q.data(), active.data(), lambda.data()), 1);
    }
  // A W that is not positive definite is refused, not solved into garbage.
  contact::ComplementaritySolver solver(2);
  const double W[4] = {1, 2, 2, 1}, q[2] = {-1, -1};
  double       lambda[2];
  char         active[2] = {1, 1};
  EXPECT_EQ(solver.solve(2, W, 2, q, active, lambda), -1);
}

// A free body's contact row meets the rigid body's step compliance through its lever r =
// (X + u - c) x n, taken at the deformed point the kind's displacement callback gives (where
// FreeBody's torque acts), anew at every step: also for a row kept from the last step, whose
// deformation part of W is reused. One vertex 5 cm from the centre, 1 mm into a rigid floor,
// no deformation compliance: W = tau^2/4m + r . T r and the force is 1 mm / W.
namespace
{
  // One input vertex at X, and a rigid body's step compliance tau^2/4m = 1e-3 m/N,
  // tau^2/4 I^-1 = 0.5 / (N m).
  irdm::ModelFrame
  one_vertex(const std::array<double, 3> &X)
  {
    irdm::ModelFrame m;
    m.n_inputs = m.n_outputs = 3;
    m.output_coordinates     = {X};
    m.output_input_index     = {0};
    m.input_output_index     = {0};
    return m;
  }
  irdm::RigidStepCompliance
  unit_rigid_compliance()
  {
    irdm::RigidStepCompliance rigid;
    rigid.tau2_over_mass       = 1e-3;
    rigid.tau2_inverse_inertia = 0.5 * Eigen::Matrix3d::Identity();
    return rigid;
  }
} // namespace

TEST(Runtime, FreeBodyContactLeversAreAtTheDeformedPointsEveryStep)
{
  const irdm::ModelFrame m = one_vertex({0.05, 0.0, 0.0});
  irdm::VertexContact    contact;
  contact.reset(m, irdm::VertexContactOptions{});
  irdm::RigidStepCompliance rigid = unit_rigid_compliance();
  irdm::PlaneTarget floor;
  floor.point = {0, 0, 0.001}; // the vertex is 1 mm below it
  for (const double ux : {0.0, 0.05, -0.02, 0.05})
    {
      double     force = 0;
      const bool ok    = contact.step(
        m, &floor, 1, [](unsigned, unsigned, const std::array<double, 3> &, int, bool) { return 0.0; },
        [](unsigned, unsigned) { return 0.0; },
        [&](const unsigned k, const double f) { force += k == 2 ? f : 0.0; }, &rigid,
        [&](unsigned) { return Eigen::Vector3d(ux, 0, 0); }, 0.0,
        [](unsigned, const std::array<double, 3> &, double, Eigen::Vector3d &) { return false; });
      ASSERT_TRUE(ok);
      const double lever = 0.05 + ux; // |(X + u - c) x n|
      EXPECT_NEAR(force, 0.001 / (1e-3 + 0.5 * lever * lever), 1e-12) << "u_x = " << ux;
    }
}

// A vertex 2 cm above the floor undeformed, 4 times the margin, that the deformation has
// carried down through it: the contact takes it as a candidate by its deformed position when
// told how far the deformation reaches, and pushes it with the force that meets the floor
// (its lever at the deformed point). Told nothing (reach 0), or carried only half way, it is
// not a candidate.
TEST(Runtime, PlaneContactTakesAVertexTheDeformationCarriedPastTheMargin)
{
  const irdm::ModelFrame m = one_vertex({0.05, 0.0, 0.02});
  irdm::VertexContact    contact;
  contact.reset(m, irdm::VertexContactOptions{}); // margin 5 mm
  irdm::RigidStepCompliance rigid = unit_rigid_compliance();
  irdm::PlaneTarget floor; // z = 0
  for (const double uz : {-0.021, -0.01})
    for (const double reach : {0.0, 0.03})
      {
        double     force = 0;
        const bool ok    = contact.step(
          m, &floor, 1,
          [&](unsigned, unsigned, const std::array<double, 3> &n, int, bool) { return n[2] * uz; },
          [](unsigned, unsigned) { return 0.0; },
          [&](const unsigned k, const double f) { force += k == 2 ? f : 0.0; }, &rigid,
          [&](unsigned) { return Eigen::Vector3d(0, 0, uz); }, reach,
          [&](unsigned, const std::array<double, 3> &n, const double limit, Eigen::Vector3d &u) {
            u = Eigen::Vector3d(0, 0, uz);
            return n[2] * uz < limit;
          });
        ASSERT_TRUE(ok);
        const bool seen = reach > 0 && uz < -0.015; // 0.02 + uz < margin
        EXPECT_EQ(contact.candidates(), seen ? 1 : 0) << "u_z = " << uz << ", reach " << reach;
        EXPECT_EQ(contact.deformed_candidates(), seen ? 1 : 0);
        // 1 mm into the floor; lever |(X + u) x n| = 0.05.
        EXPECT_NEAR(force, seen ? 0.001 / (1e-3 + 0.5 * 0.05 * 0.05) : 0.0, 1e-12)
          << "u_z = " << uz << ", reach " << reach;
      }
}

// The complementarity solver's fallback, projected Gauss-Seidel: on a positive definite W it
// converges to block principal pivoting's exact answer; on a W that is not, which the solver
// refuses, it still gives forces that never pull.
TEST(Planes, ProjectedGaussSeidelConvergesToTheExactAnswerAndNeverPulls)
{
  const int           n = 30;
  std::vector<double> W, q, exact(n), pgs(n, 0.0), g(n);
  random_problem(n, 0.5, 777, W, q);
  contact::ComplementaritySolver solver(n);
  std::vector<char>              active(n, 0);
  ASSERT_GT(solver.solve(n, W.data(), n, q.data(), active.data(), exact.data()), 0);
  std::vector<double> errors;
  double              scale = 0;
  for (const int sweeps : {1, 3, 10, 300})
    {
      std::fill(pgs.begin(), pgs.end(), 0.0);
      contact::projected_gauss_seidel(n, W.data(), n, q.data(), pgs.data(), sweeps, g.data());
      double error = 0;
      for (int i = 0; i < n; ++i)
        error = std::max(error, std::abs(pgs[i] - exact[i])), scale = std::max(scale, exact[i]);
      errors.push_back(error);
    }
  EXPECT_GT(errors[0], 1e-3 * scale) << "one sweep is not the answer: the test sees convergence";
  for (size_t k = 1; k < errors.size(); ++k)
    EXPECT_LE(errors[k], errors[k - 1]);
  EXPECT_LT(errors.back(), 1e-10 * scale);
  const double bad[4] = {1, 2, 2, 1}, q2[2] = {-1, -1};
  double       lambda[2] = {0, 0}, g2[2];
  char         on[2]     = {1, 1};
  ASSERT_EQ(solver.solve(2, bad, 2, q2, on, lambda), -1);
  contact::projected_gauss_seidel(2, bad, 2, q2, lambda, 50, g2);
  for (int i = 0; i < 2; ++i)
    {
      EXPECT_GE(lambda[i], 0);
      EXPECT_TRUE(std::isfinite(lambda[i]) && std::isfinite(g2[i]));
    }
}

// More vertices near a plane than the contact's capacity: the step is taken, with the deepest
// max_candidates solved and the step counted; the same step with room solves them all. Ten
// vertices 1 mm apart in height under a floor at 4.5 mm, each its own spring of 1e-3 m/N (no
// coupling): the five below the floor are pushed by their depth over 1e-3 m/N; with room for
// four, the shallowest of them (4 mm, 0.5 mm deep) is left out this step.
TEST(Planes, TooManyCandidatesSolveTheDeepestAndAreCounted)
{
  irdm::ModelFrame m;
  const unsigned   nv = 10;
  m.n_inputs = m.n_outputs = 3 * nv;
  for (unsigned v = 0; v < nv; ++v)
    {
      m.output_coordinates.push_back({0.01 * v, 0.0, 0.001 * v});
      m.output_input_index.push_back(static_cast<int>(v));
      m.input_output_index.push_back(static_cast<int>(v));
    }
  irdm::PlaneTarget floor;
  floor.point = {0, 0, 0.0045};
  for (const unsigned capacity : {4u, 10u})
    {
      irdm::VertexContact        contact;
      irdm::VertexContactOptions o;
      o.max_candidates = capacity;
      contact.reset(m, o);
      std::vector<double> f(nv, 0.0);
      const bool          ok = contact.step(
        m, &floor, 1, [](unsigned, unsigned, const std::array<double, 3> &, int, bool) { return 0.0; },
        [](const unsigned k, const unsigned j) { return k == j ? 1e-3 : 0.0; },
        [&](const unsigned k, const double x) { f[k / 3] += k % 3 == 2 ? x : 0.0; });
      ASSERT_TRUE(ok) << capacity;
      EXPECT_EQ(contact.candidates(), static_cast<int>(std::min(capacity, nv)));
      EXPECT_EQ(contact.limited_steps(), capacity < nv ? 1u : 0u);
      EXPECT_EQ(contact.fallback_steps(), 0u);
      for (unsigned v = 0; v < nv; ++v)
        {
          const double depth = std::max(0.0, 0.0045 - 0.001 * v);
          const bool   left  = capacity == 4 && v == 4;
          EXPECT_NEAR(f[v], left ? 0.0 : depth / 1e-3, 1e-12) << "vertex " << v << ", room " << capacity;
        }
    }
  // A feed-through that is not positive definite (invalid data): the solve refuses, projected
  // Gauss-Seidel answers, the step is taken and counted, and no force pulls.
  irdm::VertexContact contact;
  contact.reset(m, irdm::VertexContactOptions{});
  std::vector<double> f(nv, 0.0);
  ASSERT_TRUE(contact.step(
    m, &floor, 1, [](unsigned, unsigned, const std::array<double, 3> &, int, bool) { return 0.0; },
    [](const unsigned k, const unsigned j) { return k % 3 == 2 && j % 3 == 2 ? (k == j ? 1e-3 : 2e-3) : 0.0; },
    [&](const unsigned k, const double x) { f[k / 3] += k % 3 == 2 ? x : 0.0; }));
  EXPECT_EQ(contact.fallback_steps(), 1u);
  for (const double x : f)
    EXPECT_TRUE(std::isfinite(x) && x >= 0);
}
