// The reduced nonlinear model (issue 50): with the full basis and every element it is the
// neo-Hookean FEM's own run (same law, integrator and penalty planes), to Newton's tolerance;
// with a small basis, modal derivatives carry what the linear modes miss of a large bend.
#include <irdm/cubature.h>
#include <irdm/reduced_nonlinear.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/reduced_model.h>
#include <reference_fem/scene.h>

#include <gtest/gtest.h>

#include <validation/fem_verification.h>

#include "irdm_test_util.h"
#include "metrics.h"

#include <Eigen/Dense>

#include <cmath>

using namespace irdm;
using irdm::validation::BeamModel;
using irdm::validation::beam_scene_json;

namespace
{
  // The clamped beam_2 (0.25 m, 2 cm square) pressed at its free end's top edge by a plane
  // tilted 45 degrees, `depth` (m) into it over `ramp` (s), then held.
  fem::Scene
  pressed_beam(const double depth, const double ramp, const double duration)
  {
    const double s = 1 / std::sqrt(2.0);
    const auto   at = [&](const double d) {
      return "[" + std::to_string(0.25 - d * s) + ", 0, " + std::to_string(0.01 - d * s) + "]";
    };
    return fem::parse_scene(
      beam_scene_json(IRDM_MESH_DIR "/beam_2.msh", 1, BeamModel(),
                      R"(, "kinematics": "nonlinear",
         "damping": {"ratios": [0.02, 0.02], "frequencies_Hz": [1, 50]},
         "integrator": {"type": "generalized_alpha", "rho_inf": 0.8},
         "time": {"step_s": 0.002, "duration_s": )" + std::to_string(duration) + R"(},
         "planes": [{"name": "press", "normal": [-1, 0, -1],
                     "position": {"times_s": [0, )" + std::to_string(ramp) + R"(], "points_m": [)" + at(-1e-4) + ", " + at(depth) + R"(]}}],
         "model": {"inputs": {"within": {"center_m": [0.25, 0.005, 0.01], "radius_m": 0.015}}},
         "outputs": {"surface": true})"),
      ".");
  }

  // The reduced model's run of the scene's plane: per step, the plane's force on the body and
  // the surface displacement (the FEM's surface order).
  struct ReducedRun
  {
    std::vector<std::array<double, 3>> force;
    std::vector<std::vector<double>>   surface;
    unsigned long                      failed = 0;
    // A floating body's angular momentum's change over the run, and the external torque's
    // impulse (the trapezoid of the steps' end torques).
    Eigen::Vector3d angular_change = Eigen::Vector3d::Zero(), torque_impulse = Eigen::Vector3d::Zero();
  };

  ReducedRun
  run_reduced(const ReducedNonlinearModel &m, const fem::Scene &s, const ReducedBodyOptions &options = {})
  {
    ReducedNonlinearBody body(m, options);
    ReducedRun           out;
    if (s.gravity_enabled || s.fixed_surfaces.empty()) // the scene's gravity and start velocity
      {
        EXPECT_TRUE(body.start(s.gravity_enabled ? s.gravity : fem::Vec3{0, 0, 0}, s.initial_velocity,
                               s.initial_angular_velocity));
      }
    const auto           &plane = s.planes.at(0);
    const Eigen::Vector3d L0    = body.angular_momentum();
    Eigen::Vector3d       torque = Eigen::Vector3d::Zero(); // none at the start: nothing touches yet
    for (unsigned k = 1; k <= s.n_steps(); ++k)
      {
        const double    t = k * s.time_step;
        ReducedPlane    p;
        const fem::Vec3 x = plane.position.at(t), n = plane.normal_at(t);
        p.point           = {x[0], x[1], x[2]};
        p.normal          = {n[0], n[1], n[2]};
        body.step(&p, 1);
        out.force.push_back(body.plane_force(0));
        out.surface.emplace_back(3 * m.surface_vertex.size());
        body.surface_displacement(out.surface.back().data());
        out.torque_impulse += 0.5 * s.time_step * (torque + body.external_torque());
        torque = body.external_torque();
      }
    out.failed         = body.failed_steps();
    out.angular_change = body.angular_momentum() - L0;
    return out;
  }

  // max_k |a_k - b_k| over max_k |b_k|, over every step and component.
  double
  relative_max(const std::vector<std::vector<double>> &a, const std::vector<std::vector<double>> &b)
  {
    double diff = 0, scale = 0;
    for (size_t k = 0; k < a.size(); ++k)
      for (size_t i = 0; i < a[k].size(); ++i)
        {
          diff  = std::max(diff, std::abs(a[k][i] - b[k][i]));
          scale = std::max(scale, std::abs(b[k][i]));
        }
    return diff / scale;
  }

  std::vector<std::vector<double>>
  fem_forces(const fem::RunResult &r)
  {
    std::vector<std::vector<double>> F;
    for (size_t k = 1; k < r.time.size(); ++k)
      F.push_back({r.plane_force.at("press")[k][0], r.plane_force.at("press")[k][1],
                   r.plane_force.at("press")[k][2]});
    return F;
  }

  std::vector<std::vector<double>>
  forces(const ReducedRun &r)
  {
    std::vector<std::vector<double>> F;
    for (const auto &f : r.force)
      F.push_back({f[0], f[1], f[2]});
    return F;
  }

  std::vector<std::vector<double>>
  fem_surface(const fem::RunResult &r)
  {
    return {r.surface_displacement.begin() + 1, r.surface_displacement.end()};
  }

  // A stiffer beam (f1 about 3.5 Hz) bent by a tip load ramped over 0.3 s to a linear
  // deflection of a third of its length (P1 beam_2 locks: it bends less), and held.
  struct Bend
  {
    BeamModel  beam;
    double     F = 0; // N, downward at the end of the ramp
    fem::Scene scene;
    Bend()
    {
      beam.youngs_modulus = 2e7;
      F                   = 0.33 * beam.length / beam.tip_deflection(1.0);
      scene               = fem::parse_scene(
        beam_scene_json(IRDM_MESH_DIR "/beam_2.msh", 1, beam,
                        R"(, "kinematics": "nonlinear",
           "damping": {"ratios": [0.05, 0.05], "frequencies_Hz": [1, 50]},
           "integrator": {"type": "generalized_alpha", "rho_inf": 0.8},
           "time": {"step_s": 0.002, "duration_s": 0.4},
           "loads": [{"type": "surface_force", "surface": "tip", "total_force_N": [0, 0, )" +
                          std::to_string(-F) + R"(], "history": {"times_s": [0, 0.3], "factors": [0, 1]}}],
           "outputs": {"surface": true})"),
        ".");
      // The FEM's load on the surface vertices: a uniform traction on P1 triangles gives each
      // vertex a third of its triangles' areas.
      const fem::SurfaceMesh b = fem::ElasticDynamics(scene).boundary();
      tip_share.assign(b.coordinates.size(), 0.0);
      double total = 0;
      for (size_t t = 0; t < b.triangles.size(); ++t)
        if (b.triangle_surface[t] == "tip")
          {
            const auto           &p = b.coordinates;
            const auto           &v = b.triangles[t];
            const Eigen::Vector3d e1(p[v[1]][0] - p[v[0]][0], p[v[1]][1] - p[v[0]][1], p[v[1]][2] - p[v[0]][2]);
            const Eigen::Vector3d e2(p[v[2]][0] - p[v[0]][0], p[v[2]][1] - p[v[0]][1], p[v[2]][2] - p[v[0]][2]);
            const double          area = 0.5 * e1.cross(e2).norm();
            total += area;
            for (const unsigned i : v)
              tip_share[i] += area / 3;
          }
      for (double &a : tip_share)
        a /= total;
    }
    std::vector<double> tip_share; // per surface vertex: its share of the tip load

    /// The reduced model's surface at every step 1..N.
    std::vector<std::vector<double>>
    run(const ReducedNonlinearModel &m, unsigned long *failed = nullptr) const
    {
      ReducedNonlinearBody            body(m);
      std::vector<ReducedVertexForce> load;
      std::vector<std::vector<double>> out;
      for (unsigned k = 1; k <= scene.n_steps(); ++k)
        {
          const double factor = std::min(1.0, k * scene.time_step / 0.3);
          load.clear();
          for (unsigned i = 0; i < tip_share.size(); ++i)
            if (tip_share[i] > 0)
              load.push_back({i, {0, 0, -F * factor * tip_share[i]}});
          body.step(nullptr, 0, load.data(), static_cast<int>(load.size()));
          out.emplace_back(3 * m.surface_vertex.size());
          body.surface_displacement(out.back().data());
        }
      if (failed)
        *failed = body.failed_steps();
      return out;
    }

    std::string
    model(const unsigned modes, const unsigned derivative_modes) const
    {
      fem::ReducedModelOptions o;
      o.output = irdm_test::tmp("reduced_bend_" + std::to_string(modes) + "_" + std::to_string(derivative_modes) + ".h5");
      o.modes            = modes;
      o.derivative_modes = derivative_modes;
      o.residual_modes   = false;
      o.basis_size       = 12;
      fem::precompute_reduced_model(scene, o);
      return o.output;
    }
  };

  // Relative L2 over every step and component; `reference` may start at step 0 (FEM runs).
  double
  surface_error(const std::vector<std::vector<double>> &test,
                const std::vector<std::vector<double>> &reference)
  {
    const size_t           offset = reference.size() - test.size();
    validation::RelativeL2 e;
    for (size_t k = 0; k < test.size(); ++k)
      e.add(test[k], reference[k + offset]);
    return e.value();
  }

  // The every-element reduced model of the scene with 9 fields, and the same model with
  // every mode of (K_0, M) from the dense matrices on the free DoFs as its basis.
  struct FullBasis
  {
    ReducedNonlinearModel small, full;
  };

  FullBasis
  full_basis_model(const fem::Scene &s, const std::string &file)
  {
    const bool               free_body = s.fixed_surfaces.empty();
    fem::ReducedModelOptions o;
    o.output           = irdm_test::tmp(file);
    o.modes            = 6;
    o.derivative_modes = 2;
    o.residual_modes   = false;
    o.basis_size       = free_body ? 21 : 9; // a free body's six rigid modes first, its six uniform strain fields
    fem::precompute_reduced_model(s, o);
    FullBasis out{load_reduced_nonlinear_model(o.output, s.time_step), {}};
    EXPECT_EQ(out.small.elements.size(), out.small.cubature_elements.size()) << "no cubature: every element";
    const fem::ElasticDynamics linear(s);
    const fem::DenseSystem     ds = linear.dense_free_system();
    const auto                 n  = static_cast<Eigen::Index>(ds.n_free);
    const Eigen::MatrixXd K = Eigen::Map<const Eigen::MatrixXd>(ds.stiffness.data(), n, n);
    const Eigen::MatrixXd M = Eigen::Map<const Eigen::MatrixXd>(ds.mass.data(), n, n);
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(K, M);
    EXPECT_EQ(eig.info(), Eigen::Success);
    out.full      = out.small;
    auto &m       = out.full;
    m.size        = ds.n_free;
    m.basis.assign(3ull * m.n_vertices * m.size, 0.0);
    for (size_t row = 0; row < ds.vertex_dof_to_free.size(); ++row)
      if (ds.vertex_dof_to_free[row] >= 0)
        for (unsigned k = 0; k < m.size; ++k)
          m.basis[row * m.size + k] = eig.eigenvectors()(ds.vertex_dof_to_free[row], k);
    // The rigid fields' loads of the new basis, U^T M w.
    const fem::NonlinearElasticity nl(s);
    const auto                     rigid = nl.rigid_fields();
    m.rigid_loads.assign(6ull * m.size, 0.0);
    for (unsigned j = 0; j < 6; ++j)
      {
        const std::vector<double> Mw = nl.mass_product(rigid.fields[j]);
        for (size_t row = 0; row < Mw.size(); ++row)
          for (unsigned k = 0; k < m.size; ++k)
            m.rigid_loads[6 * k + j] += m.basis[row * m.size + k] * Mw[row];
      }
    return out;
  }
} // namespace

// Every element and a basis of every mode of (K_0, M): the reduced model spans the FEM's whole
// space, so its run is the FEM's (the same neo-Hookean law, objective damping, generalized-alpha
// and node-based penalty), to the two Newton solves' tolerance. The large press bends the
// beam's end about 10 mm, well into geometric nonlinearity. Both with U's own rows and with
// the runtime's default, the rows rounded to float (a basis 6e-8 off, spanning the same space
// to that: the run is the FEM's to the same bound).
TEST(ReducedModel, WithTheFullBasisItIsTheNonlinearFemRun)
{
  const fem::Scene s   = pressed_beam(0.01, 0.02, 0.024);
  const auto       fem = fem::NonlinearElasticity(s).run();
  const ReducedNonlinearModel m = full_basis_model(s, "reduced_full.h5").full;

  ReducedBodyOptions exact;
  exact.single_precision_rows = false;
  for (const bool rounded : {false, true})
    {
      const ReducedRun reduced = run_reduced(m, s, rounded ? ReducedBodyOptions{} : exact);
      EXPECT_EQ(reduced.failed, 0u);
      const double force_error   = relative_max(forces(reduced), fem_forces(fem));
      const double surface_error = relative_max(reduced.surface, fem_surface(fem));
      std::cout << "full basis, rows in " << (rounded ? "float" : "double") << ": force error "
                << force_error << ", surface error " << surface_error << "\n";
      EXPECT_LT(force_error, 1e-7);
      EXPECT_LT(surface_error, 1e-7);
    }
  double bend = 0;
  for (const auto &u : fem_surface(fem))
    for (const double x : u)
      bend = std::max(bend, std::abs(x));
  EXPECT_GT(bend, 5e-3) << "the press must reach large displacement";
  std::cout << "largest displacement " << bend << " m\n";
}


// A free body: the beam thrown down and spinning under gravity onto a floor. With every mode
// as the basis the reduced model is the FEM here too: the rigid start velocity, gravity's load
// and the start's balance are the FEM's. With 21 fields (the six rigid modes first, 6 elastic
// modes, the six uniform strain fields and 3 directions of their derivatives) it flies as the FEM does (translations are
// exact) and deforms at contact within what the basis holds. With every mode, its angular
// momentum changes by the floor's torque impulse, to the integrator's error, and with 21
// fields too with the true torques (the default; the projected ones miss it by more).
TEST(ReducedModel, AFreeBodyWithTheFullBasisIsTheNonlinearFemRun)
{
  const fem::Scene s = fem::parse_scene(
    R"({"format": "irdm-scene/1", "name": "free_beam", "mesh": {"file": ")" IRDM_MESH_DIR R"(/beam_2.msh"},
      "fe_degree": 1, "material": {"youngs_modulus_Pa": 2e4, "poisson_ratio": 0.4, "density_kg_m3": 1100},
      "damping": {"ratios": [0.02, 0.02], "frequencies_Hz": [1, 50]},
      "integrator": {"type": "generalized_alpha", "rho_inf": 0.8}, "kinematics": "nonlinear",
      "time": {"step_s": 0.002, "duration_s": 0.05}, "gravity": {"enabled": true},
      "initial_velocity_m_s": [0.1, 0, -0.6], "initial_angular_velocity_rad_s": [0, 2, 0],
      "planes": [{"name": "press", "normal": [0, 0, 1], "position": {"times_s": [0], "points_m": [[0, 0, -0.01]]}}],
      "model": {"length": 10}, "outputs": {"surface": true}})",
    ".");
  const auto      fem = fem::NonlinearElasticity(s).run();
  const FullBasis b   = full_basis_model(s, "reduced_free.h5");
  ASSERT_EQ(b.small.rigid_modes, 6u);
  ReducedBodyOptions exact; // U's own rows: with every mode the basis holds e x (U q) exactly
  exact.single_precision_rows = false;
  const ReducedRun full = run_reduced(b.full, s, exact);
  EXPECT_EQ(full.failed, 0u);
  const double force_error   = relative_max(forces(full), fem_forces(fem));
  const double surface_error = relative_max(full.surface, fem_surface(fem));
  double       peak = 0;
  for (const auto &f : fem_forces(fem))
    peak = std::max(peak, std::abs(f[2]));
  EXPECT_GT(peak, 0.1) << "the beam must land";
  EXPECT_LT(force_error, 1e-6);
  EXPECT_LT(surface_error, 1e-6);
  // Before the landing every run is free flight: the 21-field model's surface is the FEM's
  // to what its 9 elastic fields hold of the flight's small deformation (the beam turns
  // about 0.02 rad before it lands, which its frame carries exactly).
  ReducedBodyOptions projected; // the Galerkin projection's own torques
  projected.keep_angular_momentum = false;
  ReducedBodyOptions exact_projected = projected;
  exact_projected.single_precision_rows = false;
  const ReducedRun small           = run_reduced(b.small, s);
  const ReducedRun small_projected = run_reduced(b.small, s, projected);
  const ReducedRun full_projected  = run_reduced(b.full, s, exact_projected);
  // With every mode the projected torques are the true ones; with 21 fields the landing's
  // balance is the integrator's with the true torques (the projected ones turn the beam
  // besides).
  EXPECT_LT(relative_max(forces(full_projected), forces(full)), 1e-10);
  const auto imbalance = [](const ReducedRun &r) { return (r.angular_change - r.torque_impulse).norm() / r.torque_impulse.norm(); };
  EXPECT_LT(imbalance(small), 0.01);
  EXPECT_GT(imbalance(small_projected), 2 * imbalance(small));
  EXPECT_EQ(small.failed, 0u);
  EXPECT_EQ(small_projected.failed, 0u);
  for (const ReducedRun *run : {&full, &full_projected, &small, &small_projected})
    std::cout << (run == &full ? "full basis" : run == &full_projected ? "full basis, projected torques"
                                                : run == &small        ? "21 fields"
                                                                       : "21 fields, projected torques")
              << ": angular momentum changed by " << run->angular_change.transpose() << ", the torque's impulse "
              << run->torque_impulse.transpose() << "; force against the full basis's "
              << relative_max(forces(*run), forces(full)) << "\n";
  unsigned         first = 0;
  while (first < full.force.size() && full.force[first][2] == 0)
    ++first;
  ASSERT_GT(first, 1u);
  const auto                             fem_all = fem_surface(fem);
  const std::vector<std::vector<double>> fem_flight(fem_all.begin(), fem_all.begin() + first);
  const std::vector<std::vector<double>> flight(small.surface.begin(), small.surface.begin() + first);
  const double flight_error = relative_max(flight, fem_flight);
  EXPECT_LT(flight_error, 2e-3);
  // Angular momentum: the change is the torque's impulse, to the integrator's error.
  EXPECT_GT(full.torque_impulse.norm(), 1e-4) << "the landing turns the beam";
  EXPECT_LT((full.angular_change - full.torque_impulse).norm(), 0.01 * full.torque_impulse.norm());
  std::cout << "free body, full basis: force " << force_error << ", surface " << surface_error
            << ", peak force " << peak << " N; 21 fields in flight (" << first << " steps) "
            << flight_error << ", whole run force " << relative_max(forces(small), fem_forces(fem)) << "\n";
}

// A free beam tumbling end over end at 10 rad/s, no gravity and nothing to touch, for about a
// turn. The six uniform strain fields in a free body's basis hold every finite rotation of the
// undeformed body (a basis with the six rigid modes alone strains it by theta^2 / 2 and loses
// it). The floating frame also turns what the body's deformation is with it, and stays closer
// to the FEM than one frame for the whole run. In free flight for 10 s it gains no energy and
// keeps its angular momentum within 2e-3 with the projected torques, and ten times closer with
// the true ones (the default).
TEST(ReducedModel, ATumblingFreeBodyKeepsItsShapeInTheFloatingFrame)
{
  const auto scene = [](const double duration) {
    return fem::parse_scene(
      R"({"format": "irdm-scene/1", "name": "tumbling_beam", "mesh": {"file": ")" IRDM_MESH_DIR R"(/beam_2.msh"},
        "fe_degree": 1, "material": {"youngs_modulus_Pa": 2e5, "poisson_ratio": 0.4, "density_kg_m3": 1100},
        "damping": {"ratios": [0, 0], "frequencies_Hz": [1, 50]},
        "integrator": {"type": "generalized_alpha", "rho_inf": 0.8}, "kinematics": "nonlinear",
        "time": {"step_s": 0.002, "duration_s": )" + std::to_string(duration) + R"(},
        "initial_angular_velocity_rad_s": [1, 10, 0],
        "planes": [{"name": "press", "normal": [0, 0, 1], "position": {"times_s": [0], "points_m": [[0, 0, -10]]}}],
        "model": {"length": 10}, "outputs": {"surface": true}})",
      ".");
  };
  const fem::Scene s   = scene(0.6);
  const auto       fem = fem::NonlinearElasticity(s).run();
  const FullBasis  b   = full_basis_model(s, "reduced_tumbling.h5");
  const ReducedRun floating = run_reduced(b.small, s);
  EXPECT_EQ(floating.failed, 0u);
  const double floating_error = relative_max(floating.surface, fem_surface(fem));

  ReducedBodyOptions linearized;
  linearized.floating_frame = false;
  ReducedNonlinearBody body(b.small, linearized);
  ASSERT_TRUE(body.start({0, 0, 0}, {0, 0, 0}, s.initial_angular_velocity));
  std::vector<std::vector<double>> surface;
  ReducedPlane                     far;
  far.point = {0, 0, -10};
  for (unsigned k = 1; k <= s.n_steps(); ++k)
    {
      body.step(&far, 1);
      surface.emplace_back(3 * b.small.surface_vertex.size());
      body.surface_displacement(surface.back().data());
    }
  const double linearized_error = relative_max(surface, fem_surface(fem));
  EXPECT_LT(floating_error, 0.01);
  EXPECT_LT(linearized_error, 0.05) << "the uniform strain fields hold the turn";
  EXPECT_GT(linearized_error, 2 * floating_error);

  const fem::Scene     flight = scene(10);
  ReducedBodyOptions   projected; // the Galerkin projection's own torques
  projected.keep_angular_momentum = false;
  ReducedNonlinearBody free_body(b.small, projected);
  ReducedNonlinearBody kept(b.small);
  ASSERT_TRUE(free_body.start({0, 0, 0}, {0, 0, 0}, flight.initial_angular_velocity));
  ASSERT_TRUE(kept.start({0, 0, 0}, {0, 0, 0}, flight.initial_angular_velocity));
  const double          start = free_body.energy();
  const Eigen::Vector3d L0    = free_body.angular_momentum();
  double                most  = start, last = start, L_drift = 0, kept_drift = 0, kept_most = start;
  for (unsigned k = 1; k <= flight.n_steps(); ++k)
    {
      free_body.step(&far, 1);
      kept.step(&far, 1);
      last = free_body.energy();
      most = std::max(most, last);
      kept_most = std::max(kept_most, kept.energy());
      L_drift = std::max(L_drift, (free_body.angular_momentum() - L0).norm() / L0.norm());
      kept_drift = std::max(kept_drift, (kept.angular_momentum() - L0).norm() / L0.norm());
    }
  // With the true torques the angular momentum is the integrator's (the 21 fields do not hold
  // the turned spin stretch, so the projected internal force has a torque of its own).
  EXPECT_LT(kept_drift, 0.1 * L_drift);
  EXPECT_LT(kept_most, start * (1 + 1e-3)) << "no energy gained";
  EXPECT_LT(kept.energy(), start) << "no energy gained";
  std::cout << "true torques: angular momentum within " << kept_drift << ", energy at most " << kept_most
            << ", at the end " << kept.energy() << "\n";
  // At the start, the rigid spin's: the box's inertia (the P1 consistent mass holds the
  // second moments of a linear field exactly) times the spin; then kept to the integrator's
  // and the basis's error.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto &x : b.small.coordinates)
    lo = lo.cwiseMin(Eigen::Vector3d(x[0], x[1], x[2])), hi = hi.cwiseMax(Eigen::Vector3d(x[0], x[1], x[2]));
  const Eigen::Vector3d e  = (hi - lo).cwiseAbs2() * b.small.mass / 12;
  const Eigen::Vector3d w(flight.initial_angular_velocity[0], flight.initial_angular_velocity[1],
                          flight.initial_angular_velocity[2]);
  const Eigen::Vector3d L_box((e(1) + e(2)) * w(0), (e(0) + e(2)) * w(1), (e(0) + e(1)) * w(2));
  EXPECT_LT((L0 - L_box).norm(), 1e-9 * L_box.norm());
  EXPECT_LT(L_drift, 2e-3);
  // The start holds no stretch yet; the spin's stretch takes some of the kinetic energy as
  // it builds, with the integrator's wobble about its share, and never more.
  EXPECT_EQ(free_body.failed_steps(), 0u);
  EXPECT_LT(most, start * (1 + 1e-3)) << "no energy gained";
  EXPECT_LT(last, start) << "no energy gained";
  EXPECT_GT(last, 0.99 * start) << "nor much lost";
  std::cout << "tumbling beam, a turn, 21 fields: surface error " << floating_error
            << " (floating frame), " << linearized_error << " (rotations linearized); 10 s of flight: "
            << "energy " << start << " J, at most " << most << ", at the end " << last
            << "; angular momentum within " << L_drift << " of its start\n";
}

// The cubature's FEM training states (fem_training_states) are the FEM's snapshots projected
// on the basis, q = U^T M u. With every mode as the basis the reduced model is the FEM (the
// test above), so they are the reduced model's own training states on the same presses, and
// the basis misses nothing; with 9 fields it misses part of each snapshot and says so.
TEST(ReducedModel, FemTrainingStatesAreTheReducedModelsOwnWithTheFullBasis)
{
  const fem::Scene s = pressed_beam(0.01, 0.02, 0.024);
  const FullBasis  b = full_basis_model(s, "reduced_fem_training.h5");
  TrainingOptions  t;
  t.presses    = 2;
  t.max_depth  = 0.006;
  t.ramp_steps = 6;
  t.every      = 3;
  const TrainingSet reduced = training_states(b.full, t);
  ASSERT_EQ(reduced.failed_steps, 0u);
  std::vector<fem::TrainingPress> presses;
  for (size_t p = 0; p < reduced.depths.size(); ++p)
    presses.push_back({reduced.directions[p], reduced.supports[p], reduced.depths[p]});
  fem::FemTrainingOptions o;
  o.ramp_steps = t.ramp_steps;
  o.every      = t.every;
  const auto fem = fem::fem_training_states(s, b.full.basis, b.full.size, presses, o);
  EXPECT_EQ(fem.failed_presses, 0u);
  ASSERT_EQ(fem.states.size(), reduced.states.size());
  ASSERT_EQ(fem.states.size(), 8u) << "2 presses of 12 steps, a state every 3";
  double largest = 0, difference = 0;
  for (size_t k = 0; k < fem.states.size(); ++k)
    {
      const Eigen::Map<const Eigen::VectorXd> q(fem.states[k].data(), b.full.size);
      largest    = std::max(largest, reduced.states[k].norm());
      difference = std::max(difference, (q - reduced.states[k]).norm());
    }
  EXPECT_GT(largest, 0);
  EXPECT_LT(difference, 1e-6 * largest);
  EXPECT_LT(fem.largest_projection_error, 1e-6);

  const auto few = fem::fem_training_states(s, b.small.basis, b.small.size, presses, o);
  EXPECT_EQ(few.states.size(), fem.states.size());
  EXPECT_GT(few.largest_projection_error, 1e-3) << "9 fields do not hold a press's local dent";
  EXPECT_LT(few.largest_projection_error, 1);
  std::cout << "FEM training states against the reduced model's: " << difference / largest
            << "; the basis misses " << fem.largest_projection_error << " (every mode), "
            << few.largest_projection_error << " (9 fields)\n";
}

// A large bend is not a sum of linear modes: the beam's end also moves back along its axis
// (by the square of the bend), and its section turns. At the same basis size, modal
// derivatives (how the lowest modes change with their own amplitude) carry that; without them
// the reduced neo-Hookean body stiffens (it cannot shorten), as Barbic and James describe.
TEST(ReducedModel, ModalDerivativesCarryWhatTheLinearModesMissOfALargeBend)
{
  const Bend bend;
  const auto fem = fem::NonlinearElasticity(bend.scene).run();
  unsigned long failed = 0;
  const double  modes_only =
    surface_error(bend.run(load_reduced_nonlinear_model(bend.model(12, 0)), &failed), fem.surface_displacement);
  EXPECT_EQ(failed, 0u);
  const double with_derivatives =
    surface_error(bend.run(load_reduced_nonlinear_model(bend.model(6, 3)), &failed), fem.surface_displacement);
  EXPECT_EQ(failed, 0u);
  double axial = 0, sag = 0; // the tip's, at the end
  for (size_t i = 0; i < bend.tip_share.size(); ++i)
    if (bend.tip_share[i] > 0)
      {
        axial = std::min(axial, fem.surface_displacement.back()[3 * i]);
        sag   = std::min(sag, fem.surface_displacement.back()[3 * i + 2]);
      }
  std::cout << "tip: sag " << sag << " m, axial " << axial << " m; surface error: 12 modes "
            << modes_only << ", 6 modes and the derivatives of 3 " << with_derivatives << "\n";
  EXPECT_LT(sag, -0.015) << "a large bend";
  EXPECT_LT(axial, -0.05 * std::abs(sag)) << "its end moves back along the axis";
  EXPECT_LT(with_derivatives, 0.01);
  EXPECT_GT(modes_only, 20 * with_derivatives);
}

// The cubature, trained on presses by planes from random directions (not the bend), keeps the
// bend of the model with every element on a fraction of the elements; a tighter tolerance
// takes more elements and comes closer.
TEST(ReducedModel, CubatureTrainedElsewhereKeepsTheBend)
{
  const Bend                  bend;
  const std::string           file  = bend.model(6, 3);
  const ReducedNonlinearModel every = load_reduced_nonlinear_model(file);
  const auto                  reference = bend.run(every);
  TrainingOptions             t;
  t.presses   = 8;
  t.max_depth = 0.01;
  const TrainingSet training = training_states(every, t);
  EXPECT_EQ(training.failed_steps, 0u);
  std::vector<double> errors;
  std::vector<size_t> sizes;
  for (const double tolerance : {0.05, 0.01, 0.002})
    {
      CubatureOptions o;
      o.tolerance      = tolerance;
      const Cubature c = train_cubature(every, training.states, o);
      const std::string out = irdm_test::tmp("reduced_bend_cubature.h5");
      std::filesystem::remove(out);
      write_cubature_model(file, out, c, training);
      const ReducedNonlinearModel reduced = load_reduced_nonlinear_model(out);
      unsigned long failed = 0;
      const double error = surface_error(bend.run(reduced, &failed), reference);
      std::cout << "tolerance " << tolerance << ": " << c.elements.size() << " of "
                << every.elements.size() << " elements, training " << c.training_error
                << ", bend error " << error << ", failed " << failed << "\n";
      EXPECT_LE(c.training_error, tolerance);
      EXPECT_EQ(failed, 0u);
      EXPECT_EQ(reduced.cubature_elements.size(), c.elements.size()) << "the file holds it";
      EXPECT_FALSE(reduced.every_element);
      errors.push_back(error);
      sizes.push_back(c.elements.size());
    }
  EXPECT_LT(errors[1], 0.01);
  EXPECT_LT(sizes[1], every.elements.size() / 3);
  EXPECT_LT(errors[2], errors[0] / 10);
  EXPECT_LT(sizes[0], sizes[1]);
  EXPECT_LT(sizes[1], sizes[2]);
}

// Lawson and Hanson's non-negative least squares finds a known answer with zeros in it, and
// never a negative weight where the unconstrained answer has one.
TEST(ReducedModel, NonNegativeLeastSquaresFindsTheKnownAnswer)
{
  std::srand(3);
  const Eigen::MatrixXd A = Eigen::MatrixXd::Random(40, 12);
  Eigen::VectorXd       x(12);
  x << 1, 0, 2, 0, 0, 0.5, 3, 0, 0.1, 0, 4, 0;
  const Eigen::VectorXd found = non_negative_least_squares(A, A * x);
  EXPECT_LT((found - x).norm(), 1e-10 * x.norm());
  // b off the cone: the unconstrained fit has negative entries, the answer none, and the
  // residual is orthogonal to the columns it uses and points away from the others.
  const Eigen::VectorXd b      = A * x - 3 * A.col(1);
  const Eigen::VectorXd plain  = A.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd y      = non_negative_least_squares(A, b);
  const Eigen::VectorXd w      = A.transpose() * (b - A * y);
  EXPECT_LT(plain.minCoeff(), 0);
  EXPECT_GE(y.minCoeff(), 0);
  for (Eigen::Index i = 0; i < y.size(); ++i)
    if (y(i) > 0)
      EXPECT_NEAR(w(i), 0, 1e-9 * b.norm() * A.norm());
    else
      EXPECT_LE(w(i), 1e-9 * b.norm() * A.norm());
}



// A free body at rest on a frictionless floor: the floor's forces are vertical and gravity acts
// at the centre of mass, so nothing turns the body about the vertical. The small cat with 21
// fields rocks on its base for a second. Its projected forces (the internal force and the
// floor's, on a basis that does not hold e x (U q)) have a vertical torque of their own, which
// spins it up; with the projected torques made the true ones (keep_angular_momentum) its
// vertical angular momentum stays within the integrator's error, 1e-3 of the rocking's. Newton
// converges at every step either way (the tangent leaves the correction out). The cat hops on
// the penalty floor (out of contact on some steps), so round-off decides each figure: the
// bounds sit outside their spread over summation orders and floors shifted by picometres
// (reports/reduced/step_cost/README.md).
TEST(ReducedModel, AFreeBodyRestingOnAFrictionlessFloorDoesNotSpinUp)
{
  const fem::Scene s = fem::parse_scene(
    R"({"format": "irdm-scene/1", "name": "resting_cat", "mesh": {"file": ")" IRDM_MESH_DIR R"(/cat.msh"},
      "fe_degree": 1, "material": {"youngs_modulus_Pa": 5e4, "poisson_ratio": 0.45, "density_kg_m3": 1100},
      "damping": {"ratios": [0.02, 0.02], "frequencies_Hz": [1, 50]},
      "integrator": {"type": "generalized_alpha", "rho_inf": 0.8}, "kinematics": "nonlinear",
      "time": {"step_s": 0.002, "duration_s": 1}, "gravity": {"enabled": true},
      "planes": [{"name": "floor", "normal": [0, 0, 1], "position": {"times_s": [0], "points_m": [[0, 0, -10]]}}],
      "model": {"length": 10}})",
    ".");
  fem::ReducedModelOptions o;
  o.output           = irdm_test::tmp("reduced_resting_cat.h5");
  o.modes            = 6;
  o.derivative_modes = 2;
  o.residual_modes   = false;
  o.basis_size       = 21;
  fem::precompute_reduced_model(s, o);
  const ReducedNonlinearModel m = load_reduced_nonlinear_model(o.output, s.time_step);
  ReducedPlane                floor; // touching the cat's lowest vertex
  floor.point = {0, 0, 1e300};
  for (const auto &x : m.coordinates)
    floor.point[2] = std::min(floor.point[2], x[2]);
  const auto run = [&](const bool keep, double &rocking, unsigned long &iterations) {
    ReducedBodyOptions options;
    options.keep_angular_momentum = keep;
    ReducedNonlinearBody body(m, options);
    EXPECT_TRUE(body.start({0, 0, -9.81}));
    double   spin = 0;
    unsigned touching = 0;
    rocking    = 0;
    iterations = 0;
    for (unsigned k = 1; k <= s.n_steps(); ++k)
      {
        body.step(&floor, 1);
        iterations += body.newton_iterations();
        touching += body.plane_vertices(0) > 0;
        const Eigen::Vector3d L = body.angular_momentum();
        spin    = std::max(spin, std::abs(L(2)));
        rocking = std::max(rocking, L.head<2>().norm());
      }
    EXPECT_EQ(body.failed_steps(), 0u);
    EXPECT_EQ(body.cut_steps(), 0u);
    EXPECT_GT(touching, s.n_steps() / 2) << "the cat stands on the floor";
    return spin;
  };
  double        rocking = 0, kept_rocking = 0;
  unsigned long iterations = 0, kept_iterations = 0;
  const double  spin = run(false, rocking, iterations), kept = run(true, kept_rocking, kept_iterations);
  EXPECT_GT(rocking, 1e-4) << "it rocks";
  EXPECT_GT(kept_rocking, 1e-4) << "it rocks";
  EXPECT_LT(kept, 1e-3 * kept_rocking);
  EXPECT_GT(spin, 0.01 * rocking) << "the projected torque spins it up (what the option takes out)";
  std::cout << "resting cat, 21 fields, 1 s: largest vertical angular momentum " << spin << " kg m^2/s (rocking "
            << rocking << "), with the projected torques the true ones " << kept << " (rocking " << kept_rocking << "); Newton iterations " << iterations << " and "
            << kept_iterations << " over " << s.n_steps() << " steps\n";
}
