#include <irdm/modal_model.h>
#include <irdm_common/error.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "probe_step.h"
#include "surface_product.h"
#include "vertex_contact_step.h"

namespace irdm
{
  namespace
  {
    using Vec    = Eigen::Map<const Eigen::VectorXd>;
    using VecMut = Eigen::Map<Eigen::VectorXd>;
    using Arr    = Eigen::Map<const Eigen::ArrayXd>;
    using ArrMut = Eigen::Map<Eigen::ArrayXd>;
  } // namespace

  namespace
  {
    using RowMajor  = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    using FloatRows = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

    // The force loop's feed-through among the inputs, [i][k]: H[0] from the file, or from
    // the modes alone. With K < N modes the modes beyond K respond quasi-statically to this
    // step's force (mode-acceleration method), so the feed-through trades their one-step
    // response q_i[0] for their static compliance 1 / omega_i^2 (M-orthonormal shapes):
    // H[0] + sum_{i >= K} phi_i l_i^T (1 / omega_i^2 - q_i[0]), l_i the load shape (phi_i
    // itself unless a free body's rigid-fit route gave it its own). A held force then meets
    // the body's full static compliance.
    void
    set_feed_through(ModalModel &out, const ImpulseResponseModel &m,
                     const Eigen::Map<const RowMajor> &phi_in, const Eigen::Map<const RowMajor> &load_in)
    {
      const ModalData &md  = m.modes;
      const unsigned   N   = md.n_modes, nin = m.n_inputs;
      out.h0_inputs.resize(static_cast<size_t>(nin) * nin);
      if (m.modal_only)
        {
          // H[0] = Phi_in diag(q[0]) L_in^T, q_i[0] the mode's displacement after one unit
          // force sample from rest: the step's b_new for u (entry [0][3]).
          Eigen::VectorXd q0(N);
          for (unsigned i = 0; i < N; ++i)
            q0[i] = md.step[15 * static_cast<size_t>(i) + 3];
          Eigen::Map<RowMajor>(out.h0_inputs.data(), nin, nin).noalias() =
            phi_in * q0.asDiagonal() * load_in.transpose();
        }
      else
        for (unsigned k = 0; k < nin; ++k)
          for (unsigned i = 0; i < nin; ++i)
            out.h0_inputs[static_cast<size_t>(i) * nin + k] =
              m.h(k, 0, 3 * m.input_output_index[i / 3] + i % 3);
      if (out.force_modes == N)
        return;
      const unsigned  D = N - out.force_modes;
      Eigen::VectorXd c(D);
      for (unsigned i = 0; i < D; ++i)
        {
          const unsigned mode = out.force_modes + i;
          if (!(out.w2[mode] > 0))
            throw InputError("modal model: mode " + std::to_string(mode) +
                             " has no positive frequency; keep every mode in the force loop");
          c[i] = 1 / out.w2[mode] - md.step[15 * static_cast<size_t>(mode) + 3];
        }
      // h0_inputs[i][k]: to the output of input i (phi) from input DoF k (its load shape).
      const RowMajor dropped_load = load_in.rightCols(D), dropped_phi = phi_in.rightCols(D);
      Eigen::Map<RowMajor>(out.h0_inputs.data(), nin, nin).noalias() +=
        dropped_phi * c.asDiagonal() * dropped_load.transpose();
    }

    // Static gain of each of the first n modes over the model's length T: sum_{s<T} q_i[s].
    std::vector<double>
    modal_gains(const ModalModel &out, const unsigned n, const unsigned T)
    {
      std::vector<double> gain(n, 0.0);
      for (unsigned i = 0; i < n; ++i)
        {
          const double *A    = &out.step[15 * i];
          double        x[3] = {0, 0, 0}, f_old = 0;
          for (unsigned s = 0; s < T; ++s)
            {
              const double f_new = s == 0 ? 1.0 : 0.0, y[3] = {x[0], x[1], x[2]};
              for (int r = 0; r < 3; ++r)
                x[r] = A[5 * r] * y[0] + A[5 * r + 1] * y[1] + A[5 * r + 2] * y[2] +
                       A[5 * r + 3] * f_new + A[5 * r + 4] * f_old;
              f_old = f_new;
              gain[i] += x[0];
            }
        }
      return gain;
    }

    // The static correction E = sum_s H[s] - Phi_M diag(gain) Phi_M(inputs)^T (the load
    // shapes on the right when they differ), [input DoF][output DoF], from a model without
    // H: sum_s H[s] = Phi_out diag(gain) L_in^T over every mode, less the surface modes'
    // share through their rounded shapes. The surface modes' terms cancel but for that
    // rounding, so E^T = Phi_out,>M diag(gain_>M) L_in,>M^T + (Phi_M - Phi~_M) diag(gain_M)
    // L_in,M^T: each mode once, no difference of two large products. In blocks of outputs, so
    // that no outputs x inputs double matrix is held.
    void
    set_static_correction_from_modes(ModalModel &out, const ImpulseResponseModel &m,
                                     const Eigen::Map<const RowMajor> &load_in,
                                     const std::vector<double> &gain)
    {
      const unsigned N = m.modes.n_modes, M = out.surface_modes, nin = m.n_inputs,
                     nout = m.n_outputs;
      out.residual.resize(static_cast<size_t>(nin) * nout);
      const Eigen::Map<const RowMajor>        phi_out(m.modes.shapes.data(), nout, N);
      const Eigen::Map<const FloatRows>       phi_m(out.shapes.data(), nout, M);
      const Eigen::Map<const Eigen::VectorXd> g(gain.data(), N);
      const RowMajor     weighted = load_in * g.asDiagonal(); // nin x N
      constexpr unsigned block    = 256;
      for (unsigned j0 = 0; j0 < nout; j0 += block)
        {
          const unsigned nj       = std::min(block, nout - j0);
          const auto     rows     = phi_out.middleRows(j0, nj);
          const RowMajor rounding = rows.leftCols(M) - phi_m.middleRows(j0, nj).cast<double>();
          // [input][output] for outputs j0 .. j0 + nj.
          const RowMajor e = weighted.rightCols(N - M) * rows.rightCols(N - M).transpose() +
                             weighted.leftCols(M) * rounding.transpose();
          for (unsigned k = 0; k < nin; ++k)
            for (unsigned j = 0; j < nj; ++j)
              out.residual[static_cast<size_t>(k) * nout + j0 + j] = static_cast<float>(e(k, j));
        }
    }

    // The same from the file's H: its sum over the length, less the surface modes' share.
    void
    set_static_correction_from_h(ModalModel &out, const ImpulseResponseModel &m,
                                 const std::vector<double> &gain)
    {
      const unsigned N = m.modes.n_modes, M = out.surface_modes, nin = m.n_inputs,
                     nout = m.n_outputs;
      out.residual.resize(static_cast<size_t>(nin) * nout);
      const std::vector<double> &load =
        out.input_load_shapes.empty() ? out.input_shapes : out.input_load_shapes;
      std::vector<double> h(nout), w(M);
      for (unsigned k = 0; k < nin; ++k)
        {
          std::fill(h.begin(), h.end(), 0.0);
          for (unsigned s = 0; s < m.length; ++s)
            for (unsigned j = 0; j < nout; ++j)
              h[j] += m.h(k, s, j);
          for (unsigned i = 0; i < M; ++i)
            w[i] = load[static_cast<size_t>(k) * N + i] * gain[i];
          for (unsigned j = 0; j < nout; ++j)
            {
              const float *pj  = &out.shapes[static_cast<size_t>(j) * M];
              double       sum = 0;
              for (unsigned i = 0; i < M; ++i)
                sum += static_cast<double>(pj[i]) * w[i];
              out.residual[static_cast<size_t>(k) * nout + j] = static_cast<float>(h[j] - sum);
            }
        }
    }
  } // namespace

  ModalModel
  make_modal_model(const ImpulseResponseModel &m, const ModalModelOptions &o)
  {
    const auto       t0 = std::chrono::steady_clock::now();
    const ModalData &md = m.modes;
    if (md.n_modes == 0)
      throw InputError("modal model: the model file holds no modal realization (/modes/shapes); "
                       "precompute it again with this version");
    if (o.surface_modes < 1 || o.surface_modes > md.n_modes)
      throw InputError("modal model: surface modes must be 1 .. " + std::to_string(md.n_modes));
    const unsigned force_modes = o.force_modes == 0 ? md.n_modes : o.force_modes;
    if (force_modes < o.surface_modes || force_modes > md.n_modes)
      throw InputError("modal model: force-loop modes must be " + std::to_string(o.surface_modes) +
                       " (the surface modes) .. " + std::to_string(md.n_modes));
    ModalModel out;
    out.force_modes = force_modes;
    static_cast<ModelFrame &>(out) = m;
    const unsigned N = md.n_modes, M = o.surface_modes;
    const unsigned nin = m.n_inputs, nout = m.n_outputs;
    out.n_modes              = N;
    out.surface_modes        = M;
    out.highest_frequency_hz = md.frequency_hz[M - 1];
    out.step                 = md.step;
    out.centrifugal_load     = md.centrifugal_load;
    out.inertial_modes       = md.inertial_modes;
    out.inertial_coupling    = md.inertial_coupling;
    out.w2.resize(N);
    for (unsigned i = 0; i < N; ++i)
      {
        const double omega = 2 * 3.141592653589793 * md.frequency_hz[i];
        out.w2[i]          = omega * omega;
      }
    // The surface shapes in single precision: the full surface update streams them, and half
    // the bytes is what makes it fast with cold caches. The static correction is computed
    // from these rounded shapes, so the surface keeps H's static compliance to E's own
    // (float) rounding.
    out.shapes.resize(static_cast<size_t>(nout) * M);
    for (unsigned j = 0; j < nout; ++j)
      for (unsigned i = 0; i < M; ++i)
        out.shapes[static_cast<size_t>(j) * M + i] =
          static_cast<float>(md.shapes[static_cast<size_t>(j) * N + i]);
    const auto output_of = [&](unsigned k) { return 3 * m.input_output_index[k / 3] + k % 3; };
    out.input_shapes.resize(static_cast<size_t>(nin) * N);
    for (unsigned k = 0; k < nin; ++k)
      std::copy_n(&md.shapes[static_cast<size_t>(output_of(k)) * N], N,
                  &out.input_shapes[static_cast<size_t>(k) * N]);
    if (!md.load_shapes.empty())
      {
        out.input_load_shapes.resize(static_cast<size_t>(nin) * N);
        for (unsigned k = 0; k < nin; ++k)
          std::copy_n(&md.load_shapes[static_cast<size_t>(output_of(k)) * N], N,
                      &out.input_load_shapes[static_cast<size_t>(k) * N]);
      }
    const std::vector<double> &input_load =
      out.input_load_shapes.empty() ? out.input_shapes : out.input_load_shapes;
    const Eigen::Map<const RowMajor> phi_in(out.input_shapes.data(), nin, N),
      load_in(input_load.data(), nin, N);
    set_feed_through(out, m, phi_in, load_in);
    // The surface modes' gains; every mode's when H is not stored, to sum H from the modes.
    const std::vector<double> gain = modal_gains(out, m.modal_only ? N : M, m.length);
    if (m.modal_only)
      set_static_correction_from_modes(out, m, load_in, gain);
    else
      set_static_correction_from_h(out, m, gain);
    out.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  ModalInteraction::ModalInteraction(const ModalModel &model, const VertexContactOptions &planes)
    : model_(model)
    , N_(model.force_modes)
    , M_(model.surface_modes)
    , stride_(model.n_modes)
  {
    if (N_ == 0 || N_ > model.n_modes || M_ > N_)
      throw InputError("modal interaction: the model needs 1 <= surface modes <= force-loop "
                       "modes <= modes (make_modal_model)");
    for (auto *v : {&xu_, &xv_, &xa_, &fu_, &fv_, &fa_})
      v->assign(N_, 0.0);
    coef_.resize(15 * static_cast<size_t>(N_));
    for (unsigned i = 0; i < N_; ++i)
      for (unsigned e = 0; e < 15; ++e)
        coef_[e * static_cast<size_t>(N_) + i] = model.step[15 * static_cast<size_t>(i) + e];
    g_prev_.assign(N_, 0.0);
    spin_load_.assign(N_, 0.0);
    R_ = std::min(N_, model.inertial_modes);
    frame_load_.assign(R_, 0.0);
    frame_scratch_.assign(R_, 0.0);
    momentum_scratch_.assign(R_, 0.0);
    force_now_.assign(model.n_inputs, 0.0);
    is_pushed_.assign(model.n_inputs, 0);
    pushed_.reserve(model.n_inputs);
    vertex_contact_.reset(model, planes);
    lever_u_.assign(model.n_inputs, 0.0);
    lever_set_.assign(model.n_inputs / 3, 0);
    lever_vertices_.reserve(model.n_inputs / 3);
    projected_.assign(static_cast<size_t>(planes.max_candidates) * N_, 0.0); // 8 MB at 512 x 2037
    // The plane contact's bound on each input vertex's displacement: by Cauchy-Schwarz in the
    // strain-energy norm, |u_v| <= sqrt(sum_i w_i^2 u_i^2) sqrt(sum_i |phi_i(v)|^2 / w_i^2),
    // the second factor the vertex's flexibility, fixed; over the modes past reach_modes_ too,
    // to bound what the first ones leave out. A model without positive frequencies for all
    // its force-loop modes has no such bound: every vertex then takes the full test.
    reach_modes_ = std::min(N_, reach_modes);
    bounded_     = model.w2.size() >= N_;
    for (unsigned i = 0; bounded_ && i < N_; ++i)
      bounded_ = model.w2[i] > 0 && std::isfinite(model.w2[i]);
    flexibility_all_.assign(model.n_inputs / 3, 0.0);
    flexibility_tail_.assign(model.n_inputs / 3, 0.0);
    test_shapes_.resize(static_cast<size_t>(model.n_inputs) * N_);
    xu_test_.assign(N_, 0.0f);
    for (unsigned v = 0; v < model.n_inputs / 3; ++v)
      {
        for (unsigned d = 0; d < 3; ++d)
          for (unsigned i = 0; i < N_; ++i)
            {
              const double phi = model.input_shapes[(3 * v + d) * stride_ + i];
              // [vertex][the first reach_modes_ of x, y, z][the rest of x, y, z]: each stage
              // reads one contiguous block.
              const unsigned r  = reach_modes_;
              const size_t   at = static_cast<size_t>(3 * v) * N_ +
                                (i < r ? d * r + i : 3 * r + d * (N_ - r) + (i - r));
              test_shapes_[at] = static_cast<float>(phi);
              if (!bounded_)
                continue;
              flexibility_all_[v] += phi * phi / model.w2[i];
              if (i >= reach_modes_)
                flexibility_tail_[v] += phi * phi / model.w2[i];
            }
        flexibility_all_[v]  = std::sqrt(flexibility_all_[v]);
        flexibility_tail_[v] = std::sqrt(flexibility_tail_[v]);
        largest_flexibility_ = std::max(largest_flexibility_, flexibility_all_[v]);
      }
  }

  double
  ModalInteraction::deformation_reach() const
  {
    return reach_of(std::sqrt(strain_sum(0, N_)));
  }

  double
  ModalInteraction::reach_of(const double strain_all) const
  {
    return bounded_ ? largest_flexibility_ * strain_all : std::numeric_limits<double>::infinity();
  }

  double
  ModalInteraction::strain_sum(const unsigned first, const unsigned end) const
  {
    if (!bounded_)
      return 0; // not used
    double e = 0;
    for (unsigned i = first; i < end; ++i)
      e += model_.w2[i] * xu_[i] * xu_[i];
    return e;
  }

  bool
  ModalInteraction::can_touch(const int t) const
  {
    return detail::can_touch(model_, t);
  }

  bool
  ModalInteraction::can_touch(const ProbeTarget &probe) const
  {
    return detail::can_touch(model_, probe);
  }

  void
  ModalInteraction::begin_step()
  {
    for (const unsigned k : pushed_)
      force_now_[k] = 0, is_pushed_[k] = 0;
    pushed_.clear();
    for (const unsigned v : lever_vertices_)
      lever_set_[v] = 0;
    lever_vertices_.clear();
    // The state this step reaches if its force is zero: structure of arrays, in Eigen's
    // packet arithmetic (a plain loop over the std::vector members stayed scalar, 47
    // instructions per mode: GCC 12 would not vectorize it).
    const Eigen::Index N = N_;
    const auto coef = [&](const int e) { return Arr(&coef_[static_cast<size_t>(e) * N_], N); };
    const Arr u(xu_.data(), N), v(xv_.data(), N), a(xa_.data(), N), g(g_prev_.data(), N);
    ArrMut(fu_.data(), N) = coef(0) * u + coef(1) * v + coef(2) * a + coef(4) * g;
    ArrMut(fv_.data(), N) = coef(5) * u + coef(6) * v + coef(7) * a + coef(9) * g;
    ArrMut(fa_.data(), N) = coef(10) * u + coef(11) * v + coef(12) * a + coef(14) * g;
    if (spinning_) // a known load of this step: in the history the contact solve reads
      {
        const Arr c(spin_load_.data(), N);
        ArrMut(fu_.data(), N) += coef(3) * c;
        ArrMut(fv_.data(), N) += coef(8) * c;
        ArrMut(fa_.data(), N) += coef(13) * c;
      }
    if (frame_forces_on())
      add_frame_load();
  }

  ModalInteraction::CouplingBlock
  ModalInteraction::coupling_block(const int a, const int b) const
  {
    // The stored block is inertial_modes wide; its first R_ rows and columns.
    const auto   stored = static_cast<Eigen::Index>(model_.inertial_modes);
    const size_t block  = static_cast<size_t>(stored) * static_cast<size_t>(stored);
    return CouplingBlock(&model_.inertial_coupling[static_cast<size_t>(3 * a + b) * block], R_, R_,
                         Eigen::OuterStride<>(stored));
  }

  void
  ModalInteraction::add_frame_load()
  {
    // f = -sum_ab J_ab (A_ab q + B_ab q') + |omega|^2 q (spin softening's), with
    // A = [alpha]x (Euler) + omega omega^T (spin softening) and B = 2 [omega]x (Coriolis):
    // sum_a alpha_a G_a = sum_ab [alpha]x_ab J_ab, G_a = Phi^T M [e_a]x Phi.
    const auto cross = [](const Eigen::Vector3d &v) {
      Eigen::Matrix3d m;
      m << 0, -v(2), v(1), v(2), 0, -v(0), -v(1), v(0), 0;
      return m;
    };
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero(), B = Eigen::Matrix3d::Zero();
    if (euler_)
      A += cross(alpha_);
    if (spin_softening_)
      A += omega_ * omega_.transpose();
    if (coriolis_)
      B = 2 * cross(omega_);
    const Eigen::Index R = R_;
    const Vec          q(fu_.data(), R), p(fv_.data(), R);
    VecMut             f(frame_load_.data(), R), y(frame_scratch_.data(), R);
    f.setZero();
    if (spin_softening_)
      f = omega_.squaredNorm() * q;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        {
          if (A(a, b) == 0 && B(a, b) == 0)
            continue;
          y = A(a, b) * q + B(a, b) * p;
          f.noalias() -= coupling_block(a, b) * y;
        }
    const auto coef = [&](const int e) { return Arr(&coef_[static_cast<size_t>(e) * N_], R); };
    ArrMut(fu_.data(), R) += coef(3) * f.array();
    ArrMut(fv_.data(), R) += coef(8) * f.array();
    ArrMut(fa_.data(), R) += coef(13) * f.array();
  }

  bool
  ModalInteraction::set_frame_forces(const bool euler, const bool spin_softening,
                                     const bool coriolis, const unsigned modes)
  {
    const unsigned held = static_cast<unsigned>(frame_load_.size());
    if ((euler || spin_softening || coriolis) && held == 0)
      return false;
    R_ = modes == 0 ? held : std::min(modes, held);
    euler_          = euler;
    spin_softening_ = spin_softening;
    coriolis_       = coriolis;
    return true;
  }

  bool
  ModalInteraction::load_from_start()
  {
    if (n_ != 0)
      return false;
    if (spinning_) // at rest, q'' = the modal force (M-orthonormal shapes)
      {
        VecMut(g_prev_.data(), N_) += Vec(spin_load_.data(), N_);
        VecMut(xa_.data(), N_) += Vec(spin_load_.data(), N_);
      }
    return true;
  }

  bool
  ModalInteraction::set_frame_motion(const Eigen::Vector3d &omega, const Eigen::Vector3d &alpha)
  {
    if (!omega.allFinite() || !alpha.allFinite())
      return false;
    omega_ = omega;
    alpha_ = alpha;
    return true;
  }

  bool
  ModalInteraction::set_spin(const Eigen::Vector3d &omega)
  {
    if (model_.centrifugal_load.empty() || !omega.allFinite())
      return false;
    spinning_ = !omega.isZero(0);
    if (!spinning_)
      return true;
    // -omega x (omega x r) = S r, S = |omega|^2 I - omega omega^T: mode i's load is
    // sum_ab S_ab C_i[a][b].
    const Eigen::Matrix3d S =
      omega.squaredNorm() * Eigen::Matrix3d::Identity() - omega * omega.transpose();
    for (unsigned i = 0; i < N_; ++i)
      {
        const double *C = &model_.centrifugal_load[9 * static_cast<size_t>(i)];
        double        g = 0;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            g += S(a, b) * C[3 * a + b];
        spin_load_[i] = g;
      }
    return true;
  }

  Eigen::Matrix3d
  ModalInteraction::inertia_change() const
  {
    if (model_.centrifugal_load.empty())
      return Eigen::Matrix3d::Zero();
    // Q = sum_i u_i C_i: the load's rows are contiguous, 9 per mode.
    const Eigen::Map<const Eigen::Matrix<double, 9, Eigen::Dynamic>> C(model_.centrifugal_load.data(), 9, N_);
    const Eigen::Matrix<double, 9, 1> q = C * Vec(xu_.data(), N_);
    Eigen::Matrix3d                   Q;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        Q(a, b) = q(3 * a + b);
    return 2 * Q.trace() * Eigen::Matrix3d::Identity() - Q - Q.transpose();
  }

  void
  ModalInteraction::second_order_momentum(Eigen::Vector3d &h, Eigen::Matrix3d &I2) const
  {
    h.setZero();
    I2.setZero();
    const Eigen::Index R = R_;
    if (R == 0)
      return;
    const Vec    q(xu_.data(), R), p(xv_.data(), R);
    VecMut       z(momentum_scratch_.data(), R);
    // S_ab = q^T J_ab q, T_ab = q'^T J_ab q.
    Eigen::Matrix3d S, T;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        {
          z.noalias() = coupling_block(a, b) * q;
          S(a, b) = q.dot(z);
          T(a, b) = p.dot(z);
        }
    // h_a = q'^T G_a q with G_x = J_zy - J_yz (cyclic).
    h = Eigen::Vector3d(T(2, 1) - T(1, 2), T(0, 2) - T(2, 0), T(1, 0) - T(0, 1));
    I2 = S.trace() * Eigen::Matrix3d::Identity() - 0.5 * (S + S.transpose());
  }

  void
  ModalInteraction::end_step()
  {
    // Modal force of this step, then the state.
    std::fill(g_prev_.begin(), g_prev_.end(), 0.0);
    const std::vector<double> &load =
      model_.input_load_shapes.empty() ? model_.input_shapes : model_.input_load_shapes;
    for (const unsigned k : pushed_)
      VecMut(g_prev_.data(), N_) += force_now_[k] * Vec(&load[k * stride_], N_);
    const Eigen::Index N = N_;
    const auto coef = [&](const int e) { return Arr(&coef_[static_cast<size_t>(e) * N_], N); };
    const Arr g(g_prev_.data(), N);
    ArrMut(xu_.data(), N) = Arr(fu_.data(), N) + coef(3) * g;
    ArrMut(xv_.data(), N) = Arr(fv_.data(), N) + coef(8) * g;
    ArrMut(xa_.data(), N) = Arr(fa_.data(), N) + coef(13) * g;
    if (spinning_) // fu_ holds its response already; the next step's history needs it in g
      VecMut(g_prev_.data(), N_) += Vec(spin_load_.data(), N_);
    if (frame_forces_on())
      VecMut(g_prev_.data(), R_) += Vec(frame_load_.data(), R_);
    ++n_;
  }

  // The three callbacks of probe_step and VertexContact::step for the modal model.
  double
  ModalInteraction::history_row(const unsigned i) const
  {
    return Vec(&model_.input_shapes[i * stride_], N_).dot(Vec(fu_.data(), N_));
  }

  double
  ModalInteraction::history_along(const unsigned in_vertex, const std::array<double, 3> &n,
                                  const int slot, const bool fresh)
  {
    double *row = &projected_[static_cast<size_t>(slot) * N_];
    if (fresh)
      {
        const double *phi = &model_.input_shapes[3 * in_vertex * stride_];
        VecMut(row, N_) = n[0] * Vec(phi, N_) + n[1] * Vec(phi + stride_, N_) +
                          n[2] * Vec(phi + 2 * stride_, N_);
      }
    double h = Vec(row, N_).dot(Vec(fu_.data(), N_));
    // Known forces of this step (InputForce): their feed-through to this vertex.
    for (int a = 0; a < n_applied_; ++a)
      for (unsigned d = 0; d < 3; ++d)
        for (unsigned e = 0; e < 3; ++e)
          if (applied_[a].force[e] != 0)
            h += n[d] * feed_through(3 * applied_[a].input_vertex + e,
                                     3 * model_.input_output_index[in_vertex] + d) *
                 applied_[a].force[e];
    return h;
  }

  double
  ModalInteraction::deformation_feed_through(const unsigned k, const unsigned j) const
  {
    // The input DoF whose output is output DoF j (contact rows are outputs of inputs). Stored
    // by output: the contact's W reads one output row at a time.
    const unsigned i = 3u * static_cast<unsigned>(model_.output_input_index[j / 3]) + j % 3;
    return model_.h0_inputs[static_cast<size_t>(i) * model_.n_inputs + k];
  }

  double
  ModalInteraction::feed_through(const unsigned k, const unsigned j) const
  {
    const double h = deformation_feed_through(k, j);
    if (!rigid_)
      return h;
    const auto  &x = model_.output_coordinates[j / 3];
    const auto  &y = model_.output_coordinates[model_.input_output_index[k / 3]];
    return h + rigid_->entry(Eigen::Vector3d(x[0], x[1], x[2]), static_cast<int>(j % 3),
                             Eigen::Vector3d(y[0], y[1], y[2]), static_cast<int>(k % 3));
  }

  void
  ModalInteraction::push(const unsigned k, const double f)
  {
    force_now_[k] += f;
    if (!is_pushed_[k])
      {
        is_pushed_[k] = 1;
        pushed_.push_back(k); // capacity reserved: never reallocates
      }
  }

  bool
  ModalInteraction::step(const ProbeTarget *probes, const int P)
  {
    for (int p = 0; p < P; ++p)
      if (!can_touch(probes[p]))
        return false;
    begin_step();
    detail::probe_step(
      model_, probes, P, [&](const unsigned i, unsigned) { return history_row(i); },
      [&](const unsigned k, const unsigned j) { return feed_through(k, j); },
      [&](const unsigned k, const double f) { push(k, f); }, results_);
    end_step();
    return true;
  }

  bool
  ModalInteraction::step(const PlaneTarget *planes, const int n_planes)
  {
    begin_step();
    // The known forces of a free body's step (applied_) first: the contact's history then
    // includes what they do this step.
    for (int a = 0; a < n_applied_; ++a)
      for (unsigned d = 0; d < 3; ++d)
        if (applied_[a].force[d] != 0)
          push(3 * applied_[a].input_vertex + d, applied_[a].force[d]);
    // A candidate's displacement at the step's start (the state is the step's start until
    // end_step), kept as its lever.
    const auto keep_lever = [&](const unsigned vi, const Eigen::Vector3d &u) {
      for (unsigned d = 0; d < 3; ++d)
        lever_u_[3 * vi + d] = u(d);
      if (!lever_set_[vi])
        lever_set_[vi] = 1, lever_vertices_.push_back(vi); // reserved: no allocation
    };
    // The deformed candidate test (vertex_contact.h), in three stages, each only for the
    // vertices the last could not rule out: the vertex's bound (deformation_reach's, per
    // vertex); the first reach_modes_ modes' displacement, less a bound on the rest's; the
    // displacement of every force-loop mode. The last two in single precision from a compact
    // copy of the input shapes (the full rows are scattered over a larger matrix: reading them
    // cost more than the arithmetic), with a slack far above its rounding; a vertex that
    // passes then takes its displacement in double, as every lever does.
    constexpr double slack = 1e-6; // m
    const unsigned   r           = reach_modes_;
    const double     tail        = strain_sum(r, N_);
    const double     strain_tail = std::sqrt(tail);
    const double     strain_all  = std::sqrt(strain_sum(0, r) + tail);
    for (unsigned i = 0; i < N_; ++i)
      xu_test_[i] = static_cast<float>(xu_[i]);
    const auto deformed = [&](const unsigned vi, const std::array<double, 3> &n,
                              const double limit, Eigen::Vector3d &u) {
      using VecF = Eigen::Map<const Eigen::VectorXf>;
      if (bounded_ && -strain_all * flexibility_all_[vi] >= limit)
        return false;
      const float *first = &test_shapes_[static_cast<size_t>(3 * vi) * N_], *rest = first + 3 * r;
      float        part[3];
      double       along = 0;
      for (unsigned d = 0; d < 3; ++d)
        along += n[d] * (part[d] = VecF(first + d * r, r).dot(VecF(xu_test_.data(), r)));
      if (bounded_ && along - strain_tail * flexibility_tail_[vi] - slack >= limit)
        return false;
      along = 0;
      for (unsigned d = 0; d < 3; ++d)
        along += n[d] * (part[d] + VecF(rest + d * (N_ - r), N_ - r)
                                     .dot(VecF(xu_test_.data() + r, N_ - r)));
      if (along - slack >= limit)
        return false;
      for (unsigned d = 0; d < 3; ++d)
        u(d) = input_displacement(3 * vi + d);
      keep_lever(vi, u);
      return true;
    };
    // On failure the state is left as it was (the next step's begin_step clears the pushes).
    if (!vertex_contact_.step(
          model_, planes, n_planes,
          [&](const unsigned vi, unsigned, const std::array<double, 3> &n, const int slot,
              const bool fresh) { return history_along(vi, n, slot, fresh); },
          [&](const unsigned k, const unsigned j) { return deformation_feed_through(k, j); },
          [&](const unsigned k, const double f) { push(k, f); }, rigid_,
          [&](const unsigned vi) {
            Eigen::Vector3d u;
            for (unsigned d = 0; d < 3; ++d)
              u(d) = input_displacement(3 * vi + d);
            keep_lever(vi, u);
            return u;
          },
          reach_of(strain_all), deformed))
      return false;
    end_step();
    return true;
  }

  bool
  ModalInteraction::step(const PlaneTarget *planes, const int n_planes,
                         const RigidStepCompliance &rigid)
  {
    return step(planes, n_planes, rigid, nullptr, 0);
  }

  bool
  ModalInteraction::step(const PlaneTarget *planes, const int n_planes,
                         const RigidStepCompliance &rigid, const InputForce *applied,
                         const int n_applied)
  {
    if (n_applied < 0 || (n_applied > 0 && !applied))
      return false;
    for (int a = 0; a < n_applied; ++a)
      if (applied[a].input_vertex >= model_.n_inputs / 3)
        return false;
    rigid_        = &rigid;
    applied_      = applied;
    n_applied_    = n_applied;
    const bool ok = step(planes, n_planes);
    rigid_        = nullptr;
    applied_      = nullptr;
    n_applied_    = 0;
    return ok;
  }

  double
  ModalInteraction::input_displacement(const unsigned k) const
  {
    return Vec(&model_.input_shapes[k * stride_], N_).dot(Vec(xu_.data(), N_));
  }

  double
  ModalInteraction::elastic_energy() const
  {
    double e = 0;
    for (unsigned i = 0; i < N_; ++i)
      e += xv_[i] * xv_[i] + model_.w2[i] * xu_[i] * xu_[i];
    return 0.5 * e;
  }

  namespace
  {
    // u = Phi_M u_modal + E f: the M surface modes, and the static correction of the modes
    // beyond M for this step's force (force(i) on input DoF inputs[i]).
    template <typename Force>
    void
    surface_kernel(const ModalModel &model, const double *modal_u, const unsigned *inputs,
                   const unsigned n_pushed, const Force &force, double *u)
    {
      const size_t nout = model.n_outputs;
      detail::surface_product(model.shapes.data(), model.surface_modes, nout, modal_u, u);
      for (unsigned i = 0; i < n_pushed; ++i)
        {
          const double f = force(i);
          const float *e = &model.residual[static_cast<size_t>(inputs[i]) * nout];
          for (size_t j = 0; j < nout; ++j)
            u[j] += e[j] * f;
        }
    }
  } // namespace

  void
  ModalInteraction::surface_displacement(double *u) const
  {
    surface_kernel(model_, xu_.data(), pushed_.data(), static_cast<unsigned>(pushed_.size()),
                   [&](const unsigned i) { return force_now_[pushed_[i]]; }, u);
  }

  void
  ModalInteraction::warm_step() const
  {
    double sum = 0;
    for (const std::vector<double> *v : {&coef_, &xu_, &xv_, &xa_, &g_prev_})
      for (const double x : *v)
        sum += x;
    const size_t nin = model_.n_inputs;
    for (const unsigned k : pushed_)
      {
        sum += Vec(&model_.input_shapes[k * stride_], N_).sum();
        if (!model_.input_load_shapes.empty())
          sum += Vec(&model_.input_load_shapes[k * stride_], N_).sum();
        for (const unsigned i : pushed_)
          sum += model_.h0_inputs[static_cast<size_t>(i) * nin + k];
      }
    volatile double sink = sum; // keeps the loads
    (void)sink;
  }

  void
  ModalInteraction::save_surface_state(ModalSurfaceState &state) const
  {
    if (state.modal_displacement.size() != M_ || state.pushed_inputs.size() < pushed_.size())
      throw InputError("save_surface_state: the state was not made for this model");
    state.steps = n_;
    std::copy_n(xu_.data(), M_, state.modal_displacement.data());
    state.n_pushed = static_cast<unsigned>(pushed_.size());
    for (unsigned i = 0; i < state.n_pushed; ++i)
      {
        state.pushed_inputs[i] = pushed_[i];
        state.pushed_forces[i] = force_now_[pushed_[i]];
      }
  }

  ModalSurfaceState
  make_surface_state(const ModalModel &model)
  {
    ModalSurfaceState s;
    s.modal_displacement.assign(model.surface_modes, 0.0);
    s.pushed_inputs.assign(model.n_inputs, 0);
    s.pushed_forces.assign(model.n_inputs, 0.0);
    return s;
  }

  void
  warm_surface(const ModalModel &model)
  {
    warm_surface(model, 0, 1);
  }

  void
  warm_surface(const ModalModel &model, const size_t part, const size_t parts)
  {
    if (parts == 0 || part >= parts)
      throw InputError("warm_surface: part " + std::to_string(part) + " of " +
                       std::to_string(parts));
    // One float per 64-byte line; the sum goes to a volatile so that the loads stay.
    constexpr size_t line  = 64 / sizeof(float);
    const size_t     lines = (model.shapes.size() + line - 1) / line;
    float            sum   = 0;
    for (size_t l = lines * part / parts; l < lines * (part + 1) / parts; ++l)
      sum += model.shapes[l * line];
    volatile float sink = sum;
    (void)sink;
  }

  void
  surface_displacement(const ModalModel &model, const ModalSurfaceState &state, double *u)
  {
    if (state.modal_displacement.size() != model.surface_modes ||
        state.pushed_inputs.size() < state.n_pushed)
      throw InputError("surface_displacement: the state was not made for this model");
    surface_kernel(model, state.modal_displacement.data(), state.pushed_inputs.data(),
                   state.n_pushed, [&](const unsigned i) { return state.pushed_forces[i]; }, u);
  }
} // namespace irdm
