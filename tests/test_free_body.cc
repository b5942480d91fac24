// Free (non-grounded) bodies, issue 14: the mass properties, the precompute that separates the
// rigid-body modes, and the rigid-body integrator of the runtime.
#include <irdm/rigid_body.h>
#include <irdm_common/error.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/mesh.h>

#include "irdm_test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

using namespace irdm_test;

TEST(FreeBody, MassPropertiesOfTheBeamAreThoseOfItsBox)
{
  // beam_2: the box [0, 0.25] x [0, 0.01] x [0, 0.01] m in 1920 tetrahedra.
  const fem::TetMesh         mesh = fem::read_gmsh(std::string(IRDM_MESH_DIR) + "/beam_2.msh");
  const double               rho = 1100, L = 0.25, a = 0.01, m = rho * L * a * a;
  const fem::MassProperties  mp  = fem::mass_properties(mesh, rho);
  EXPECT_NEAR(mp.mass, m, 1e-13 * m);
  EXPECT_NEAR(mp.center[0], L / 2, 1e-15);
  EXPECT_NEAR(mp.center[1], a / 2, 1e-15);
  EXPECT_NEAR(mp.center[2], a / 2, 1e-15);
  const double I[3] = {m * (a * a + a * a) / 12, m * (L * L + a * a) / 12, m * (L * L + a * a) / 12};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(mp.inertia[i][j], i == j ? I[i] : 0.0, 1e-12 * I[1]) << i << ", " << j;
}

namespace
{
  // The beam scene with nothing fixed: a free body.
  fem::Scene
  free_beam(const std::string &extra = "")
  {
    fem::Scene s = fem::parse_scene(beam_scene(extra), ".");
    s.fixed_surfaces.clear();
    return s;
  }

  // Least-squares rigid field t + theta x (x - c) through displacements d at points x; returns
  // the largest residual.
  double
  rigid_fit_residual(const std::vector<std::array<double, 3>> &x, const std::vector<double> &d)
  {
    Eigen::MatrixXd A(d.size(), 6);
    Eigen::VectorXd b(d.size());
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto &p : x)
      c += Eigen::Vector3d(p[0], p[1], p[2]) / x.size();
    for (size_t v = 0; v < x.size(); ++v)
      {
        const Eigen::Vector3d r = Eigen::Vector3d(x[v][0], x[v][1], x[v][2]) - c;
        Eigen::Matrix3d       cross;
        cross << 0, -r(2), r(1), r(2), 0, -r(0), -r(1), r(0), 0;
        A.block<3, 3>(3 * v, 0) = Eigen::Matrix3d::Identity();
        A.block<3, 3>(3 * v, 3) = -cross; // theta x r = -r x theta
        for (int i = 0; i < 3; ++i)
          b(3 * v + i) = d[3 * v + i];
      }
    const Eigen::VectorXd q = A.colPivHouseholderQr().solve(b);
    return (A * q - b).cwiseAbs().maxCoeff();
  }
} // namespace

// The free body's H is the FEM's response with its rigid part removed: stepping the FEM of the
// free beam (nothing fixed) after a unit force sample and subtracting H leaves a rigid motion
// at every step, to round-off; and the rigid part is far from round-off (the body moves).
TEST(FreeBody, PrecomputeRemovesExactlyTheRigidMotion)
{
  const fem::Scene scene = free_beam();
  fem::PrecomputeOptions o;
  o.output  = tmp("free_beam.h5");
  o.restart = true;
  o.length  = 60;
  const fem::PrecomputeReport rep = fem::precompute_impulse_responses(scene, o);
  const ImpulseResponseModel  model = load_model(o.output, scene.time_step);
  EXPECT_TRUE(rep.free_body);
  EXPECT_TRUE(model.free_body);
  EXPECT_EQ(rep.n_modes, rep.n_free - 6);
  EXPECT_EQ(model.modes.n_modes, rep.n_free - 6);
  EXPECT_GT(model.modes.frequency_hz[0], 0.5); // the first free-free bending mode, not rigid
  const fem::MassProperties mp =
    fem::mass_properties(fem::read_gmsh(scene.mesh_file), scene.density);
  EXPECT_EQ(model.mass, mp.mass);
  EXPECT_EQ(model.inertia[1][1], mp.inertia[1][1]);

  double worst = 0, scale = 0, rigid = 0;
  for (const unsigned k : {0u, 4u, model.n_inputs - 1})
    {
      const long long tag = model.input_node_tags[k / 3];
      std::string     dir = k % 3 == 0 ? "1,0,0" : k % 3 == 1 ? "0,1,0" : "0,0,1";
      fem::Scene      s   = free_beam(
        R"(, "loads": [{"type": "vertex_force", "vertex": {"node_tag": )" + std::to_string(tag) +
        R"(}, "force_N": [)" + dir + R"(], "history": {"times_s": [0, 0.002, 0.004], "factors": [0, 1, 0]}}],
        "outputs": {"surface": true})");
      s.duration = model.length * s.time_step;
      fem::ElasticDynamics fem(s);
      const auto           r = fem.run();
      std::map<long long, unsigned> at;
      for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
        at[r.surface.node_tags[i]] = i;
      for (unsigned step = 0; step < model.length; step += 3)
        {
          std::vector<double> rest(model.n_outputs);
          double              fem_max = 0;
          for (unsigned j = 0; j < model.n_outputs; ++j)
            {
              const double fem_u =
                r.surface_displacement[step + 1][3 * at.at(model.output_node_tags[j / 3]) + j % 3];
              rest[j] = fem_u - model.h(k, step, j);
              fem_max = std::max(fem_max, std::abs(fem_u));
              scale   = std::max(scale, std::abs(model.h(k, step, j)));
              rigid   = std::max(rigid, std::abs(rest[j]));
            }
          worst = std::max(worst, rigid_fit_residual(model.output_coordinates, rest));
        }
    }
  ASSERT_GT(scale, 0);
  EXPECT_GT(rigid, 0.1 * scale) << "the rigid part should not be negligible";
  EXPECT_LT(worst / scale, 1e-8) << "FEM minus H is not a rigid motion";
}

TEST(FreeBody, SparseRouteRefusesAFreeBody)
{
  fem::PrecomputeOptions o;
  o.output  = tmp("free_sparse.h5");
  o.restart = true;
  o.modes   = 20;
  EXPECT_THROW(fem::precompute_impulse_responses(free_beam(), o), irdm::InputError);
}

namespace
{
  irdm::RigidBodyInertia
  tumbling_body()
  {
    // Principal moments 1, 2, 2.5 (kg m^2) about axes turned away from the model axes.
    irdm::RigidBodyInertia in;
    in.mass   = 2;
    in.center = Eigen::Vector3d(0.1, -0.2, 0.3);
    const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    in.inertia = Q * Eigen::Vector3d(1, 2, 2.5).asDiagonal() * Q.transpose();
    return in;
  }
} // namespace

// No force: the momenta never change (bit for bit), the orientation stays a unit quaternion,
// and the energy error of the symplectic splitting stays bounded over 10 s of tumbling about
// the unstable middle axis (a drift would grow with time).
TEST(RigidBody, KeepsMomentumExactlyAndEnergyBoundedInFreeFlight)
{
  irdm::RigidBody body(tumbling_body());
  body.set_velocity(Eigen::Vector3d(0.3, -0.1, 2), Eigen::Vector3d(0.2, 3, 0.1));
  const auto   p0 = body.state().linear_momentum, L0 = body.state().angular_momentum;
  const double E0 = body.kinetic_energy(), tau = 0.002;
  double       worst_first = 0, worst_last = 0;
  const int    n = 5000;
  for (int i = 0; i < n; ++i)
    {
      body.step(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), tau);
      const double e = std::abs(body.kinetic_energy() / E0 - 1);
      (i < n / 2 ? worst_first : worst_last) = std::max(i < n / 2 ? worst_first : worst_last, e);
    }
  EXPECT_EQ(body.state().linear_momentum, p0);
  EXPECT_EQ(body.state().angular_momentum, L0);
  EXPECT_NEAR(body.state().orientation.norm(), 1.0, 1e-14);
  EXPECT_NEAR((body.state().position - tumbling_body().center).norm(), 10 * p0.norm() / 2, 1e-10);
  EXPECT_LT(worst_first, 1e-3);
  EXPECT_LT(worst_last, 1.5 * worst_first + 1e-12) << "energy drifts";
}

// A symmetric top (I1 = I2 = A, I3 = C): the body-frame angular momentum turns about the
// symmetry axis at Omega = L3 (1/C - 1/A). The splitting is second order: halving the step
// quarters the error.
TEST(RigidBody, SymmetricTopPrecessesAtSecondOrder)
{
  irdm::RigidBodyInertia in;
  in.mass    = 1;
  in.inertia = Eigen::Vector3d(1, 1, 1.6).asDiagonal();
  const Eigen::Vector3d L0(0.7, -0.2, 1.3);
  const double          Omega = L0(2) * (1 / 1.6 - 1.0), t_end = 2;
  const Eigen::Vector3d exact(L0(0) * std::cos(Omega * t_end) + L0(1) * std::sin(Omega * t_end),
                              L0(1) * std::cos(Omega * t_end) - L0(0) * std::sin(Omega * t_end),
                              L0(2));
  double error[2];
  for (int r = 0; r < 2; ++r)
    {
      irdm::RigidBody     body(in);
      irdm::RigidBodyState s = body.state();
      s.angular_momentum   = L0;
      body.set_state(s);
      const double tau = 0.01 / (1 << r);
      for (int i = 0; i < static_cast<int>(std::lround(t_end / tau)); ++i)
        body.step(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), tau);
      error[r] = (body.rotation().transpose() * body.state().angular_momentum - exact).norm();
    }
  EXPECT_LT(error[0], 1e-3);
  EXPECT_NEAR(error[0] / error[1], 4, 0.2);
}

// The rigid share of the contact feed-through: a small force at Y during one step moves X by
// step_compliance(X, Y) times the force, to first order. At rest this is exact to first order
// (the central difference leaves O(eps^2)); spinning, the step's rotation adds O(tau omega).
TEST(RigidBody, StepComplianceIsTheFirstOrderResponseOfAStep)
{
  const irdm::RigidBodyInertia in = tumbling_body();
  const double                 tau = 0.002;
  const Eigen::Vector3d        X(0.3, 0.1, -0.2), Y(-0.2, 0.4, 0.5), F_model(0.3, -1.1, 0.8);
  for (const double spin : {0.0, 1.0})
    {
      irdm::RigidBody      body(in);
      irdm::RigidBodyState s = body.state();
      s.orientation =
        Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0, 1, 1).normalized()));
      body.set_state(s);
      body.set_velocity(Eigen::Vector3d(0.1, 0, 0), spin * Eigen::Vector3d(0.5, -0.4, 0.2));
      // Where X is after one step with the force scaled, in the frame of the body before it.
      const auto moved = [&](const double scale) {
        irdm::RigidBody       b = body;
        const Eigen::Vector3d F = b.rotation() * (scale * F_model);
        b.step(F, (b.rotation() * (Y - in.center)).cross(F), tau);
        return Eigen::Vector3d(body.rotation().transpose() * b.to_world(X));
      };
      const double          eps       = 1e-3;
      const Eigen::Vector3d numeric   = (moved(eps) - moved(-eps)) / (2 * eps);
      const Eigen::Vector3d predicted = body.step_compliance(X, Y, tau) * F_model;
      EXPECT_LT((numeric - predicted).norm(), (spin == 0 ? 1e-6 : 1e-2) * predicted.norm())
        << "spin " << spin;
    }
}

TEST(RigidBody, RefusesWhatNoBodyHas)
{
  irdm::RigidBodyInertia in = tumbling_body();
  in.mass                   = 0;
  EXPECT_THROW(irdm::RigidBody{in}, irdm::InputError);
  in         = tumbling_body();
  in.inertia = Eigen::Vector3d(1, 1, 3).asDiagonal(); // 1 + 1 < 3
  EXPECT_THROW(irdm::RigidBody{in}, irdm::InputError);
  in.inertia(0, 1) = 0.5; // not symmetric
  EXPECT_THROW(irdm::RigidBody{in}, irdm::InputError);
}
