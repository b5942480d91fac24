// Nonlinear dynamics with rigid-plane penalty contact: the linear solver's time loop
// (elastodynamics_run.cc) with Newton's method at each step, the residual being the
// generalized-alpha balance with the neo-Hookean internal force.
#include <irdm_common/error.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <string>

#include "nonlinear_impl.h"

namespace irdm::fem
{
  PlaneContactState
  NonlinearElasticity::Impl::plane_contact(const Vector<double> &u, const double t,
                                           Vector<double> &f_c, SparseMatrix<double> *K) const
  {
    const auto &L      = linear;
    const auto &planes = L.scene.planes;
    PlaneContactState s;
    s.force.assign(planes.size(), Vec3{0, 0, 0});
    s.penetration.assign(planes.size(), -1e300);
    f_c.reinit(L.dof_handler.n_dofs());
    if (planes.empty())
      return s;
    const FEValuesExtractors::Vector displacement(0);
    FEFaceValues<3> fv(L.mapping, L.fe, contact_quadrature,
                       update_values | update_quadrature_points | update_JxW_values);
    const unsigned n_dofs = L.fe.n_dofs_per_cell();
    std::vector<types::global_dof_index> dofs(n_dofs);
    std::vector<Tensor<1, 3>>            u_q(contact_quadrature.size());
    std::vector<double>                  n_phi(n_dofs);
    Vector<double>                       cell_f(n_dofs);
    FullMatrix<double>                   cell_K(n_dofs, n_dofs);
    const auto position = [&](const unsigned vertex) {
      Point<3> x;
      for (unsigned d = 0; d < 3; ++d)
        x[d] = L.mesh.vertices[vertex][d] + u[L.dofs_of_vertex[vertex][d]];
      return x;
    };
    for (unsigned p = 0; p < planes.size(); ++p)
      {
        Tensor<1, 3> n;
        Point<3>     x0;
        const Vec3   at = planes[p].position.at(t), normal = planes[p].normal_at(t);
        for (unsigned d = 0; d < 3; ++d)
          {
            n[d]  = normal[d];
            x0[d] = at[d];
          }
        const double k     = penalty[p];
        const auto   depth = [&](const Point<3> &x) { return n * (x0 - x); };
        for (const unsigned v : free_boundary_vertices)
          s.penetration[p] = std::max(s.penetration[p], depth(position(v)));
        // P1 faces are flat and touch via a vertex; a fixed vertex's contact moves nothing.
        if (L.scene.fe_degree == 1 && s.penetration[p] <= 0)
          continue;
        for (const auto &[cell, f] : boundary_faces)
          {
            // P1: the face is flat and its displacement linear, so it touches only if a
            // vertex does. P2 faces can bulge; a margin of their size covers sane meshes.
            const auto face   = cell->face(f);
            double     deepest = -1e300;
            for (const unsigned v : face->vertex_indices())
              deepest = std::max(deepest, depth(position(face->vertex_index(v))));
            double margin = 0;
            if (L.scene.fe_degree > 1)
              for (const unsigned v : face->vertex_indices())
                margin = std::max(margin, face->vertex(v).distance(face->vertex((v + 1) % 3)));
            if (deepest <= -margin)
              continue;
            fv.reinit(cell, f);
            fv[displacement].get_function_values(u, u_q);
            cell->get_dof_indices(dofs);
            cell_f = 0;
            cell_K = 0;
            bool   touched     = false;
            double face_energy = 0;
            for (const unsigned q : fv.quadrature_point_indices())
              {
                const double g = depth(fv.quadrature_point(q) + u_q[q]);
                if (g <= 0)
                  continue;
                touched        = true;
                const double dA = fv.JxW(q);
                face_energy += 0.5 * k * g * g * dA;
                for (unsigned i = 0; i < n_dofs; ++i)
                  n_phi[i] = n * fv[displacement].value(i, q);
                for (unsigned i = 0; i < n_dofs; ++i)
                  {
                    cell_f(i) += k * g * n_phi[i] * dA;
                    if (K)
                      for (unsigned j = 0; j < n_dofs; ++j)
                        cell_K(i, j) += k * n_phi[i] * n_phi[j] * dA;
                  }
              }
            if (!touched)
              continue;
            bool pushes_body = false;
            for (unsigned i = 0; i < n_dofs; ++i)
              {
                f_c(dofs[i]) += cell_f(i);
                // The resultant on the body: what the fixed DoFs take goes into the support.
                if (!L.constraints.is_constrained(dofs[i]))
                  {
                    s.force[p][L.fe.system_to_component_index(i).first] += cell_f(i);
                    pushes_body = pushes_body || cell_f(i) != 0;
                  }
              }
            // A face pressed only at fixed DoFs stores its penalty energy in the support.
            if (pushes_body)
              s.energy += face_energy;
            if (K)
              K->add(dofs, cell_K);
          }
      }
    return s;
  }

  // The time loop of one run: the state (u, v, a) and its loads at the last sample, the
  // trial state of the step being solved, and the step's residual, Newton's method and
  // cut-back. The generalized-alpha balance at the alpha levels:
  //   M a_{1-am} + C v_{1-af} + f_int(u_{1-af}) = f_{1-af} + f_c,{1-af}.
  class NonlinearElasticity::TimeLoop
  {
  public:
    TimeLoop(const NonlinearElasticity::Impl &impl, RunResult &out)
      : I(impl)
      , L(impl.linear)
      , sc(impl.linear.scene)
      , c(impl.linear.coeffs)
      , out(out)
      , n(impl.linear.dof_handler.n_dofs())
      , dt(sc.time_step)
      , af(c.alpha_f)
      , am(c.alpha_m)
      , h(dt)
      , k(c, h)
      , tangent(L.sparsity)
      , K_T(L.sparsity)
      , K_D(L.sparsity)
      , K_Du(L.sparsity)
    {
      for (Vector<double> *x : {&u, &v, &a, &f, &f_c, &u_new, &v_new, &a_new, &f_new, &f_c_new,
                                &f_int, &r, &du, &trial, &r_trial, &tmp, &w, &u_alpha})
        x->reinit(n);
    }

    void
    start();
    void
    record(double t);
    // Steps from t0 by dt / 2^cuts, cut back where Newton fails (below).
    void
    advance(double t0, unsigned cuts);

  private:
    const NonlinearElasticity::Impl &I;
    const ElasticDynamics::Impl     &L;
    const Scene                     &sc;
    const IntegratorCoefficients    &c;
    RunResult                       &out;
    const unsigned                   n;
    const double                     dt, af, am;
    // The length of the step being solved: tau, or a part of it where Newton failed at tau
    // (cut back); the residual and its tangent follow it.
    double           h;
    StepCoefficients k;

    Vector<double> u, v, a, f, f_c; // state n and its loads
    Vector<double> u_new, v_new, a_new, f_new, f_c_new;
    Vector<double> f_int, r, du, trial, r_trial, tmp, w, u_alpha;
    SparseMatrix<double> tangent, K_T, K_D, K_Du;
    PlaneContactState    contact;
    // The latest factorized tangent, reused while it makes the residual contract (null: use
    // the linear solver's K_eff, factored for tau).
    std::unique_ptr<DirectSolver> tangent_solver;
    // Scene::body_frame_law: the body frame's rotation, held over a step (the law is then
    // linear in u within it), taken at the alpha level of the step's constant-velocity
    // predictor, u + (1 - alpha_f) h v: the turn within the step is then off by O((w h)^2).
    Tensor<2, 3> frame = I.identity();
    Tensor<1, 3> frame_spin; // rad/s, world: the frame's turn over the step (damping_force)
    double       scale = 0; // a force scale of the latest residual, for the convergence test
    double       total_mass   = sc.density * L.total_volume; // kg
    double       energy_start = 0; // J, the total energy of the first sample

    bool
    residual(double t1, const Vector<double> &x, Vector<double> &res, SparseMatrix<double> *T,
             PlaneContactState &cs);
    std::string
    newton_step(double t1);
    void
    accept()
    {
      u.swap(u_new);
      v.swap(v_new);
      a.swap(a_new);
      f.swap(f_new);
      f_c.swap(f_c_new);
    }
    static void
    combine(Vector<double> &x, const double p, const Vector<double> &y, const double q,
            const Vector<double> &z)
    {
      x.equ(p, y);
      x.add(q, z);
    }
  };

  // The initial state: the scene's velocity, its loads and contact at t = 0, and the
  // acceleration that balances them, M a0 = f(0) + f_c(0) - C v0 (f_int(0) = 0).
  void
  NonlinearElasticity::TimeLoop::start()
  {
    v = L.initial_velocity();
    L.external_force(0.0, f);
    contact            = I.plane_contact(u, 0.0, f_c, nullptr);
    Vector<double> rhs = f;
    rhs += f_c;
    L.mass.vmult(tmp, v);
    rhs.add(-sc.rayleigh_alpha, tmp);
    L.stiffness.vmult(tmp, v);
    rhs.add(-sc.rayleigh_beta, tmp);
    L.constraints.set_zero(rhs);
    if (rhs.l2_norm() > 0)
      {
        DirectSolver m_inverse;
        m_inverse.initialize(L.condensed(L.mass));
        m_inverse.solve(rhs);
        a = rhs;
      }
  }

  void
  NonlinearElasticity::TimeLoop::record(const double t)
  {
    const PlaneContactState &cs = contact;
    // The linear record() takes the fixed reactions as M a + C v + K_0 u - f; passing
    // f + f_c + K_0 u - f_int(u) makes them the nonlinear balance M a + C v + f_int - f - f_c.
    double                                   W = 0;
    NonlinearElasticity::Impl::StrainMeasure strain;
    I.assemble(u, f_int, nullptr, false, &W, &strain,
               sc.body_frame_law ? I.body_rotation(u) : I.identity());
    out.largest_strain.push_back(strain.largest);
    out.strained_volume_fraction.push_back(strain.strained_volume_fraction);
    Vector<double> balance(n);
    L.stiffness.vmult(balance, u);
    balance += f;
    balance += f_c;
    balance -= f_int;
    const Vector<double> no_lambda;
    L.record(u, v, a, balance, no_lambda, t, out);
    out.strain_energy.back() = W;
    out.contact_energy.push_back(cs.energy);
    out.gravity_energy.push_back(-(L.gravity_force * u));
    const double mechanical = out.kinetic_energy.back() + W + cs.energy;
    const double total      = mechanical + out.gravity_energy.back();
    if (t == 0)
      energy_start = total;
    out.energy_rise  = std::max(out.energy_rise, total - energy_start);
    out.energy_scale = std::max(out.energy_scale, mechanical);
    L.mass.vmult(balance, v);
    Vec3 momentum = {0, 0, 0};
    for (unsigned i = 0; i < n; ++i)
      momentum[L.dof_component[i]] += balance[i];
    out.linear_momentum.push_back(momentum);
    // Centre-of-mass displacement: 1^T M u per axis over the mass (M consistent).
    L.mass.vmult(balance, u);
    Vec3 moment = {0, 0, 0};
    for (unsigned i = 0; i < n; ++i)
      moment[L.dof_component[i]] += balance[i];
    out.center_of_mass_displacement.push_back(
      {moment[0] / total_mass, moment[1] / total_mass, moment[2] / total_mass});
    for (unsigned p = 0; p < sc.planes.size(); ++p)
      {
        out.plane_force[sc.planes[p].name].push_back(cs.force[p]);
        out.plane_penetration[sc.planes[p].name].push_back(cs.penetration[p]);
      }
  }

  // The residual of the step to t1 at the trial u_new = x (a_new, v_new follow from x by
  // Newmark). With `T`, also the tangent dR/dx, condensed. Returns false if an element
  // inverted; `scale` gets a force scale for the convergence test.
  bool
  NonlinearElasticity::TimeLoop::residual(const double t1, const Vector<double> &x, Vector<double> &res,
                     SparseMatrix<double> *T, PlaneContactState &cs)
  {
    a_new = x;
    a_new -= u;
    a_new.add(-h, v);
    a_new *= 1 / (c.beta * h * h);
    a_new.add(-(1 / (2 * c.beta) - 1), a);
    v_new = v;
    v_new.add(h * (1 - c.gamma), a, h * c.gamma, a_new);
    combine(u_alpha, 1 - af, x, af, u); // u at the alpha level
    const bool ok = I.assemble(u_alpha, f_int, T ? &K_T : nullptr, false, nullptr, nullptr, frame);
    if (sc.body_frame_law)
      I.remove_net_torque(u_alpha, f_int);
    cs            = I.plane_contact(x, t1, f_c_new, T ? &K_T : nullptr);
    combine(w, 1 - am, a_new, am, a);
    L.mass.vmult(res, w);
    scale = std::max({res.l2_norm(), f_int.l2_norm(), f_new.l2_norm(), f_c_new.l2_norm()});
    combine(w, 1 - af, v_new, af, v); // Rayleigh damping at the alpha level
    L.mass.vmult(tmp, w);
    res.add(sc.rayleigh_alpha, tmp);
    if (sc.rayleigh_beta != 0)
      {
        // Objective: no damping of rigid motion however far the body has turned.
        I.damping_force(u_alpha, w, tmp, T ? &K_D : nullptr, T ? &K_Du : nullptr, frame,
                        frame_spin);
        if (sc.body_frame_law)
          I.remove_net_torque(u_alpha, tmp);
        res.add(sc.rayleigh_beta, tmp);
      }
    res += f_int;
    res.add(-(1 - af), f_new, -(1 - af), f_c_new);
    res.add(-af, f, -af, f_c);
    L.constraints.set_zero(res);
    if (T)
      {
        // dR/dx = c_m M + c_c C(u_alpha) + (1 - af)(K_T(u_alpha) + beta sym(dC/du v) +
        // K_contact(x)), C v the objective damping force.
        T->copy_from(L.mass);
        *T *= k.c_m + k.c_c * sc.rayleigh_alpha;
        if (sc.rayleigh_beta != 0)
          {
            T->add(k.c_c * sc.rayleigh_beta, K_D);
            T->add((1 - af) * sc.rayleigh_beta, K_Du);
          }
        T->add(1 - af, K_T);
        *T = L.condensed(*T);
      }
    return ok;
  }

  // Newton's method for the step of length h that ends at t1, from the state (u, v, a, f,
  // f_c). On success the new state is in u_new, v_new, a_new, f_new, f_c_new and `contact`,
  // and it returns an empty string; on failure it returns why and leaves the state as it
  // was (the residual reads it, never writes it).
  std::string
  NonlinearElasticity::TimeLoop::newton_step(const double t1)
  {
    k = StepCoefficients(c, h);
    L.external_force(t1, f_new);
    // Constant-velocity predictor: the acceleration of a body in penalty contact changes
    // sign from step to step, so extrapolating it overshoots.
    if (sc.body_frame_law)
      {
        u_alpha = u;
        u_alpha.add((1 - af) * h, v);
        frame = I.body_rotation(u_alpha);
        Vector<double> v_alpha = v; // the predictor's velocity at the alpha level
        v_alpha.add((1 - af) * h, a);
        frame_spin = I.body_angular_velocity(u_alpha, v_alpha);
      }
    u_new = u;
    u_new.add(h, v);
    L.constraints.set_zero(u_new);
    if (!residual(t1, u_new, r, nullptr, contact))
      {
        u_new = u; // the predictor inverted an element: start from the last state
        residual(t1, u_new, r, nullptr, contact);
      }
    // Newton iterations per step: the damping's tangent is only its symmetric part, so
    // a fast, soft body can need more than the quadratic rate would. Counted as the index
    // of the iteration that found convergence; a failed attempt adds the iterations it
    // spent.
    constexpr unsigned max_newton = 100;
    for (unsigned it = 0; it < max_newton; ++it)
      {
        const double r_norm = r.l2_norm();
        if (r_norm <= 1e-7 * scale || scale == 0)
          {
            out.newton_iterations += it;
            return {};
          }
        PlaneContactState cs_trial;
        // First a step with the factors we have (the latest tangent, at first the linear
        // K_eff): kept if it contracts the residual well, which it does in smooth motion.
        du = r;
        du *= -1;
        if (tangent_solver)
          tangent_solver->solve(du);
        else
          L.stepper().inverse.solve(du);
        trial = u_new;
        trial += du;
        if (residual(t1, trial, r_trial, nullptr, cs_trial) && r_trial.l2_norm() <= 0.1 * r_norm)
          {
            u_new.swap(trial);
            r.swap(r_trial);
            contact = cs_trial;
            if (du.linfty_norm() <= 1e-12 * std::max(u_new.linfty_norm(), 1e-300))
              {
                out.newton_iterations += it;
                return {};
              }
            continue;
          }
        // Otherwise Newton's step with the tangent at u_new, and a line search.
        residual(t1, u_new, r, &tangent, contact);
        tangent_solver = std::make_unique<DirectSolver>();
        tangent_solver->initialize(tangent);
        ++out.tangent_factorizations;
        du = r;
        du *= -1;
        tangent_solver->solve(du);
        double alpha    = 1;
        bool   accepted = false;
        for (unsigned cut = 0; cut < 12; ++cut, alpha /= 2)
          {
            trial = u_new;
            trial.add(alpha, du);
            const bool ok = residual(t1, trial, r_trial, nullptr, cs_trial);
            if (ok && r_trial.l2_norm() < (1 - 1e-4 * alpha) * r_norm)
              {
                accepted = true;
                break;
              }
          }
        if (!accepted)
          {
            // No decrease: round-off if the step is negligible against the motion.
            if (du.linfty_norm() <= 1e-9 * std::max(u_new.linfty_norm(), 1e-300))
              {
                residual(t1, u_new, r, nullptr, contact);
                out.newton_iterations += it;
                return {};
              }
            out.newton_iterations += it + 1;
            return "the line search found no decrease";
          }
        u_new.swap(trial);
        r.swap(r_trial);
        contact = cs_trial;
        if (alpha == 1 && du.linfty_norm() <= 1e-12 * std::max(u_new.linfty_norm(), 1e-300))
          {
            out.newton_iterations += it;
            return {};
          }
      }
    out.newton_iterations += max_newton;
    return "Newton did not converge in " + std::to_string(max_newton) + " iterations (residual " +
           std::to_string(r.l2_norm() / scale) + " of the force scale)";
  }

  // Cut-back: where Newton fails at a step (a soft body hit hard: an element close to
  // inverting makes the tangent indefinite, and the step's incremental problem is no longer
  // convex), that step is solved again as two halves, each halved again where it fails,
  // down to tau / 2^max_cuts. The samples stay at tau; only the failed steps are refined,
  // and a finer step is the same integrator, more accurate. Counted in out.cut_steps.
  void
  NonlinearElasticity::TimeLoop::advance(const double t0, const unsigned cuts)
  {
    constexpr unsigned max_cuts = 5;
    const double       length   = dt / static_cast<double>(1u << cuts);
    h                           = length;
    const std::string error     = newton_step(t0 + length);
    if (error.empty())
      {
        accept();
        return;
      }
    if (cuts == max_cuts)
      throw InputError("nonlinear dynamics: " + error + " at t = " + std::to_string(t0 + length) +
                       " s, with the step cut back " + std::to_string(max_cuts) + " times to " +
                       std::to_string(length) + " s; a smaller time step or a softer penalty may help");
    if (cuts == 0)
      ++out.cut_steps;
    out.smallest_step = std::min(out.smallest_step, length / 2);
    advance(t0, cuts + 1);
    advance(t0 + length / 2, cuts + 1);
  }

  RunResult
  NonlinearElasticity::run(const std::function<void(double)> &progress, const SampleSink &sink,
                           const unsigned batch) const
  {
    const Impl &I  = *impl_;
    const auto &L  = I.linear;
    const auto &sc = L.scene;
    if (!(sc.duration > 0))
      throw InputError("scene '" + sc.name + "' gives no time.duration_s: nothing to run");
    if (!sc.probes.empty() || !sc.prescribed.empty())
      throw InputError("nonlinear dynamics takes loads and planes, not probes or prescribed "
                       "displacements");
    if (sc.initial != InitialState::rest)
      throw InputError("nonlinear dynamics starts at rest (initial_state 'rest'), possibly "
                       "with an initial velocity");

    RunResult out;
    L.init_result(out);
    out.setup_seconds = L.setup_seconds;
    L.stepper();
    out.factorization_seconds = L.factorization_seconds;
    for (unsigned p = 0; p < sc.planes.size(); ++p)
      out.plane_penalty[sc.planes[p].name] = I.penalty[p];

    const double   dt = sc.time_step;
    const unsigned N  = sc.n_steps();
    TimeLoop       loop(I, out);
    loop.start();
    loop.record(0.0);
    const auto t_start     = std::chrono::steady_clock::now();
    unsigned   last_report = 0;
    out.smallest_step      = dt;
    for (unsigned step = 1; step <= N; ++step)
      {
        const double t1 = step * dt;
        loop.advance(t1 - dt, 0);
        if (step % sc.outputs.every == 0 || step == N)
          {
            loop.record(t1);
            if (sink && (out.time.size() >= batch || step == N))
              {
                sink(out);
                if (step < N) // the last batch stays, for the caller's summary
                  clear_samples(out);
              }
          }
        if (progress && (20 * step) / N != last_report)
          {
            last_report = (20 * step) / N;
            progress(static_cast<double>(step) / N);
          }
      }
    out.stepping_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    out.n_steps = N;
    return out;
  }

  void
  NonlinearElasticity::write_outputs(const RunResult &result) const
  {
    impl_->linear.write_outputs(result);
  }

  unsigned
  NonlinearElasticity::n_dofs() const
  {
    return impl_->linear.dof_handler.n_dofs();
  }
} // namespace irdm::fem
