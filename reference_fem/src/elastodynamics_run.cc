// ElasticDynamics: the time loop, static equilibrium and natural frequencies.
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>

#include "elastodynamics_impl.h"

#include <Eigen/Dense>

#include <chrono>
#include <cmath>
#include <random>

namespace irdm::fem
{
  void
  ElasticDynamics::Impl::init_result(RunResult &out) const
  {
    for (unsigned i = 0; i < scene.outputs.vertices.size(); ++i)
      out.vertex_node_tag[scene.outputs.vertices[i].name] = mesh.node_tags[observed_vertex[i]];
    for (unsigned i = 0; i < scene.prescribed.size(); ++i)
      out.vertex_node_tag[scene.prescribed[i].name] = mesh.node_tags[probe_vertex[i]];
    for (const auto &p : scene.probes)
      out.vertex_node_tag[p.name] = -1; // between vertices: see probe_contact_point
    if (scene.outputs.surface)
      {
        std::vector<int> index(triangulation.n_vertices(), -1);
        for (unsigned i = 0; i < surface_vertices.size(); ++i)
          {
            const unsigned v = surface_vertices[i];
            index[v]         = static_cast<int>(i);
            out.surface.node_tags.push_back(mesh.node_tags[v]);
            out.surface.coordinates.push_back(mesh.vertices[v]);
            out.surface.mesh_vertex.push_back(v);
          }
        for (const auto &t : surface_triangles)
          out.surface.triangles.push_back({{static_cast<unsigned>(index[t[0]]),
                                            static_cast<unsigned>(index[t[1]]),
                                            static_cast<unsigned>(index[t[2]])}});
      }
  }

  void
  ElasticDynamics::Impl::record(const Vector<double> &u,
                                const Vector<double> &v,
                                const Vector<double> &a,
                                const Vector<double> &f,
                                const Vector<double> &lambda,
                                const double t,
                                RunResult &out) const
  {
    Vector<double> Mv(u.size()), Ku(u.size());
    mass.vmult(Mv, v);
    stiffness.vmult(Ku, u);
    out.time.push_back(t);
    out.kinetic_energy.push_back(0.5 * (v * Mv));
    out.strain_energy.push_back(0.5 * (u * Ku));
    const auto at_vertex = [&](const Vector<double> &x, const unsigned vertex) {
      return Vec3{x[dofs_of_vertex[vertex][0]], x[dofs_of_vertex[vertex][1]],
                  x[dofs_of_vertex[vertex][2]]};
    };
    for (unsigned i = 0; i < observed_vertex.size(); ++i)
      out.vertex_displacement[scene.outputs.vertices[i].name].push_back(
        at_vertex(u, observed_vertex[i]));
    for (unsigned i = 0; i < probe_vertex.size(); ++i)
      {
        out.probe_displacement[scene.prescribed[i].name].push_back(at_vertex(u, probe_vertex[i]));
        out.probe_force[scene.prescribed[i].name].push_back(
          {lambda[3 * i], lambda[3 * i + 1], lambda[3 * i + 2]});
      }
    for (unsigned p = 0; p < scene.probes.size(); ++p)
      {
        const auto &x    = last_probe[p];
        const auto &name = scene.probes[p].name;
        out.probe_force[name].push_back({x[0], x[1], x[2]});
        out.probe_contact_point[name].push_back({x[3], x[4], x[5]});
        out.probe_active[name].push_back(x[6] != 0);
        out.probe_displacement[name].push_back({x[7], x[8], x[9]});
      }
    // Vertex contact (linear); the nonlinear solver records its own planes.
    for (unsigned p = 0; scene.kinematics == Kinematics::linear && p < scene.planes.size(); ++p)
      {
        out.plane_force[scene.planes[p].name].push_back(last_planes[p].force);
        out.plane_penetration[scene.planes[p].name].push_back(last_planes[p].penetration);
      }
    if (!fixed_dofs.empty())
      {
        // Reaction = M a + C v + K u - f on the fixed DoFs (unconstrained matrices).
        Vector<double> r(u.size()), Ma(u.size()), Kv(u.size());
        mass.vmult(Ma, a);
        stiffness.vmult(Kv, v);
        r = Ma;
        r += Ku;
        r.add(scene.rayleigh_alpha, Mv, scene.rayleigh_beta, Kv);
        r -= f;
        for (unsigned s = 0; s < fixed_dofs.size(); ++s)
          {
            Vec3 total = {0, 0, 0};
            for (const auto i : fixed_dofs[s])
              total[dof_component[i]] += r[i];
            out.fixed_reaction[scene.fixed_surfaces[s]].push_back(total);
          }
      }
    if (scene.outputs.surface)
      {
        std::vector<double> s(3 * surface_vertices.size());
        for (unsigned i = 0; i < surface_vertices.size(); ++i)
          for (unsigned d = 0; d < 3; ++d)
            s[3 * i + d] = u[dofs_of_vertex[surface_vertices[i]][d]];
        out.surface_displacement.push_back(std::move(s));
      }
    if (scene.outputs.field)
      {
        std::vector<double> s(3 * dofs_of_vertex.size());
        for (unsigned i = 0; i < dofs_of_vertex.size(); ++i)
          for (unsigned d = 0; d < 3; ++d)
            s[3 * i + d] = u[dofs_of_vertex[i][d]];
        out.field_displacement.push_back(std::move(s));
      }
  }
} // namespace irdm::fem

namespace irdm::fem
{
  void
  ElasticDynamics::Impl::initial_state(Vector<double> &u, Vector<double> &v, Vector<double> &a,
                                       Vector<double> &f, Vector<double> &lambda) const
  {
    external_force(0.0, f);
    if (scene.initial == InitialState::static_equilibrium && !scene.probes.empty())
      throw InputError("probes need initial_state 'rest'");
    if (scene.initial == InitialState::static_equilibrium)
      {
        if (constraints.n_constraints() == 0)
          throw InputError("initial_state 'static' needs a fixed surface: a free body has "
                           "no static state");
        SparseMatrix<double> k = condensed(stiffness);
        ConstrainedSolver    statics;
        statics.initialize(k, constraints, probe_dofs);
        u      = f;
        lambda = statics.solve(constraints, u, prescribed_values(0.0), 1.0);
        for (unsigned i = 0; i < probe_dofs.size(); ++i)
          f[probe_dofs[i]] += lambda[i];
      }
    else
      {
        // Unstrained, possibly moving (a thrown or spinning body: a rigid velocity field, so
        // K v = 0): the balance M a0 = f(0) - alpha M v0 gives the initial acceleration.
        v = initial_velocity();
        a = f;
        if (scene.rayleigh_alpha > 0 && v.l2_norm() > 0)
          {
            Vector<double> Mv(dof_handler.n_dofs());
            mass.vmult(Mv, v);
            a.add(-scene.rayleigh_alpha, Mv);
          }
        constraints.set_zero(a);
        if (a.l2_norm() > 0)
          {
            SparseMatrix<double> m = condensed(mass);
            DirectSolver         m_inverse;
            m_inverse.initialize(m);
            m_inverse.solve(a);
          }
      }
  }

  void
  ElasticDynamics::Impl::start_contacts(const Vector<double> &u)
  {
    last_probe.assign(scene.probes.size(), {});
    for (unsigned p = 0; p < scene.probes.size(); ++p)
      {
        const auto sp = geometry::closest_point(mesh.vertices, probe_triangles[p],
                                                scene.probes[p].path.at(0.0));
        for (int d = 0; d < 3; ++d)
          {
            last_probe[p][3 + d] = sp.point[d];
            // The probed point's displacement at t = 0 (a coupled probe's damper needs it).
            for (int i = 0; i < 3; ++i)
              last_probe[p][7 + d] +=
                sp.weights[i] * u[dofs_of_vertex[probe_triangles[p][sp.triangle][i]][d]];
          }
      }
    plate_before.clear();
    for (const auto &plane : scene.planes)
      plate_before.push_back(plane.position.at(0.0));
    {
      // At rest: no plane force; the penetration is the undeformed surface's.
      Vector<double> u0(u), f0(dof_handler.n_dofs());
      last_planes = solve_planes(0.0, 1.0, u0, f0);
      for (auto &p : last_planes)
        p.force = {0, 0, 0};
      for (unsigned p = 0; p < scene.planes.size(); ++p)
        if (last_planes[p].penetration > 0)
          throw InputError("plane '" + scene.planes[p].name + "' starts inside the body (by " +
                           std::to_string(last_planes[p].penetration) + " m at t = 0)");
    }
  }

  RunResult
  ElasticDynamics::Impl::run(const std::function<void(double)> &progress, const SampleSink &sink,
                             const unsigned batch)
  {
    if (!(scene.duration > 0))
      throw InputError("scene '" + scene.name + "' gives no time.duration_s: nothing to run");
    RunResult out;
    init_result(out);
    for (const auto &p : scene.planes)
      out.plane_vertex_stiffness[p.name] = p.vertex_stiffness;
    out.setup_seconds         = setup_seconds;
    stepper(); // factorized before the clock of the steps starts
    out.factorization_seconds = factorization_seconds;

    const unsigned n_dofs = dof_handler.n_dofs();
    const double   dt     = scene.time_step;
    const unsigned N      = scene.n_steps();
    const auto    &c      = coeffs;

    Vector<double> u(n_dofs), v(n_dofs), a(n_dofs), f(n_dofs), lambda(probe_dofs.size());
    initial_state(u, v, a, f, lambda);
    start_contacts(u);
    record(u, v, a, f, lambda, 0.0, out);
    std::vector<std::pair<double, std::string>> vtu_records;
    if (scene.outputs.vtu_every > 0 && !scene.outputs.directory.empty())
      write_vtu(u, 0, 0.0, vtu_records);

    const StepCoefficients k(c, dt);
    const double c_m = k.c_m, c_c = k.c_c, m_v = k.m_v, m_a = k.m_a, c_v = k.c_v, c_a = k.c_a;

    Vector<double> f_new(n_dofs), rhs(n_dofs), m_part(n_dofs), c_part(n_dofs), tmp(n_dofs);
    Vector<double> u_new(n_dofs), a_new(n_dofs);
    // out = a x + b y
    const auto combine = [](Vector<double> &out, const double a, const Vector<double> &x,
                            const double b, const Vector<double> &y) {
      out.equ(a, x);
      out.add(b, y);
    };
    const auto     t_start = std::chrono::steady_clock::now();
    unsigned       last_report = 0;
    for (unsigned k = 1; k <= N; ++k)
      {
        const double t = k * dt;
        external_force(t, f_new);
        // rhs = f_{n+1-af} - af K u_n + M[...] + C[...], C = alpha M + beta K.
        combine(rhs, 1 - c.alpha_f, f_new, c.alpha_f, f);
        combine(m_part, c_m, u, m_v, v);
        m_part.add(m_a, a);
        combine(c_part, c_c, u, c_v, v);
        c_part.add(c_a, a);
        m_part.add(scene.rayleigh_alpha, c_part);
        mass.vmult_add(rhs, m_part);
        combine(tmp, scene.rayleigh_beta, c_part, -c.alpha_f, u);
        stiffness.vmult_add(rhs, tmp);

        u_new  = rhs;
        lambda = stepper().solve(constraints, u_new, prescribed_values(t), 1 - c.alpha_f);
        for (unsigned i = 0; i < probe_dofs.size(); ++i)
          f_new[probe_dofs[i]] += lambda[i];
        if (!scene.probes.empty())
          last_probe = solve_probes(t, 1 - c.alpha_f, u_new, f_new);
        if (!scene.planes.empty())
          last_planes = solve_planes(t, 1 - c.alpha_f, u_new, f_new);

        // Newmark updates of acceleration and velocity.
        a_new = u_new;
        a_new -= u;
        a_new.add(-dt, v);
        a_new *= 1 / (c.beta * dt * dt);
        a_new.add(-(1 / (2 * c.beta) - 1), a);
        v.add(dt * (1 - c.gamma), a, dt * c.gamma, a_new);
        u.swap(u_new);
        a.swap(a_new);
        f.swap(f_new);

        if (k % scene.outputs.every == 0 || k == N)
          {
            record(u, v, a, f, lambda, t, out);
            if (sink && (out.time.size() >= batch || k == N))
              {
                sink(out);
                if (k < N) // the last batch stays, for the caller's summary
                  clear_samples(out);
              }
          }
        if (scene.outputs.vtu_every > 0 && !scene.outputs.directory.empty() &&
            (k % scene.outputs.vtu_every == 0 || k == N))
          write_vtu(u, k, t, vtu_records);
        if (progress && (20 * k) / N != last_report)
          {
            last_report = (20 * k) / N;
            progress(static_cast<double>(k) / N);
          }
      }
    out.stepping_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    out.n_steps = N;
    return out;
  }

  RunResult
  ElasticDynamics::Impl::solve_static(const double t) const
  {
    if (constraints.n_constraints() == 0)
      throw InputError("static equilibrium needs at least one fixed surface "
                       "(scene key 'fixed_surfaces'): a free body has no static state");
    if (!scene.probes.empty())
      throw InputError("static equilibrium does not take probes (they are dynamic contacts)");
    RunResult out;
    init_result(out);
    const unsigned    n = dof_handler.n_dofs();
    Vector<double>    u(n), f(n), zero(n);
    SparseMatrix<double> k = condensed(stiffness);
    ConstrainedSolver statics;
    statics.initialize(k, constraints, probe_dofs);
    external_force(t, f);
    u = f;
    const Vector<double> lambda = statics.solve(constraints, u, prescribed_values(t), 1.0);
    for (unsigned i = 0; i < probe_dofs.size(); ++i)
      f[probe_dofs[i]] += lambda[i];
    record(u, zero, zero, f, lambda, t, out);
    return out;
  }

  std::vector<double>
  ElasticDynamics::Impl::natural_frequencies(const unsigned n_wanted) const
  {
    // Subspace iteration on K^{-1} M with Rayleigh-Ritz (Bathe): the block is larger than
    // the number of wanted modes so that they converge at rate lambda_i / lambda_{q+1}.
    if (constraints.n_constraints() == 0)
      throw InputError("natural frequencies need a fixed surface: a free body has rigid modes");
    const unsigned n      = dof_handler.n_dofs();
    const unsigned n_free = n - static_cast<unsigned>(constraints.n_constraints());
    if (n_wanted < 1 || n_wanted > n_free)
      throw InputError("the body has " + std::to_string(n_free) + " free DoFs, so it has 1 to " +
                       std::to_string(n_free) + " natural frequencies; " +
                       std::to_string(n_wanted) + " were asked");
    // The block never exceeds the free DoFs: more vectors would make the reduced mass singular.
    const unsigned q = std::min<unsigned>(std::max(2 * n_wanted, n_wanted + 8), n_free);
    SparseMatrix<double> k = condensed(stiffness);
    DirectSolver         k_inverse;
    k_inverse.initialize(k);

    std::mt19937                           rng(12345);
    std::uniform_real_distribution<double> uniform(-1, 1);
    std::vector<Vector<double>>            X(q, Vector<double>(n)), Y(q, Vector<double>(n));
    for (auto &x : X)
      {
        for (auto &e : x)
          e = uniform(rng);
        constraints.set_zero(x);
      }
    Eigen::VectorXd previous = Eigen::VectorXd::Zero(n_wanted);
    Vector<double>  tmp(n);
    for (unsigned iteration = 0; iteration < 200; ++iteration)
      {
        for (unsigned j = 0; j < q; ++j)
          {
            mass.vmult(Y[j], X[j]);
            constraints.set_zero(Y[j]);
            k_inverse.solve(Y[j]);
          }
        Eigen::MatrixXd Kr(q, q), Mr(q, q);
        for (unsigned j = 0; j < q; ++j)
          {
            stiffness.vmult(tmp, Y[j]);
            for (unsigned i = 0; i < q; ++i)
              Kr(i, j) = Y[i] * tmp;
            mass.vmult(tmp, Y[j]);
            for (unsigned i = 0; i < q; ++i)
              Mr(i, j) = Y[i] * tmp;
          }
        Kr = 0.5 * (Kr + Kr.transpose());
        Mr = 0.5 * (Mr + Mr.transpose());
        Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> ritz(Kr, Mr);
        const Eigen::MatrixXd &Q = ritz.eigenvectors(); // M-orthonormal, ascending
        for (unsigned j = 0; j < q; ++j)
          {
            X[j] = 0;
            for (unsigned i = 0; i < q; ++i)
              X[j].add(Q(i, j), Y[i]);
          }
        const Eigen::VectorXd current = ritz.eigenvalues().head(n_wanted);
        const double change = ((current - previous).array() / current.array()).abs().maxCoeff();
        previous = current;
        // Round-off in a Rayleigh quotient grows with cond(K) (slender, fine meshes: 1e-10 and
        // more), so ask for 1e-9 in omega^2: still far below any discretization error.
        if (iteration > 2 && change < 1e-9)
          break;
        if (iteration == 199)
          throw std::runtime_error("subspace iteration did not converge in 200 iterations");
      }
    std::vector<double> hz(n_wanted);
    for (unsigned i = 0; i < n_wanted; ++i)
      hz[i] = std::sqrt(previous[i]) / (2 * M_PI);
    return hz;
  }

  // Public facade.
  ElasticDynamics::ElasticDynamics(const Scene &scene)
    : impl_(std::make_unique<Impl>(scene))
  {}
  ElasticDynamics::~ElasticDynamics() = default;
  RunResult
  ElasticDynamics::run(const std::function<void(double)> &progress, const SampleSink &sink,
                       const unsigned batch)
  {
    return impl_->run(progress, sink, batch);
  }
  RunResult
  ElasticDynamics::solve_static(const double t) const
  {
    return impl_->solve_static(t);
  }
  std::vector<double>
  ElasticDynamics::natural_frequencies(const unsigned n) const
  {
    return impl_->natural_frequencies(n);
  }
  void
  ElasticDynamics::write_outputs(const RunResult &result) const
  {
    impl_->write_outputs(result);
  }
  unsigned
  ElasticDynamics::n_dofs() const
  {
    return impl_->dof_handler.n_dofs();
  }
  unsigned
  ElasticDynamics::n_free_dofs() const
  {
    return impl_->dof_handler.n_dofs() - static_cast<unsigned>(impl_->constraints.n_constraints());
  }
  unsigned
  ElasticDynamics::n_cells() const
  {
    return impl_->triangulation.n_active_cells();
  }
  double
  ElasticDynamics::volume() const
  {
    return impl_->total_volume;
  }
  const Scene &
  ElasticDynamics::scene() const
  {
    return impl_->scene;
  }
} // namespace irdm::fem
