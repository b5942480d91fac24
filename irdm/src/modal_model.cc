#include <irdm/modal_model.h>
#include <irdm_common/error.h>

#include <algorithm>
#include <chrono>

#include "probe_step.h"

namespace irdm
{
  ModalModel
  make_modal_model(const ImpulseResponseModel &m, const ModalModelOptions &o)
  {
    const auto t0 = std::chrono::steady_clock::now();
    const ModalData &md = m.modes;
    if (md.n_modes == 0)
      throw InputError("modal model: the model file holds no modal realization (/modes/shapes); "
                       "precompute it again with this version");
    if (o.modes < 1 || o.modes > md.n_modes)
      throw InputError("modal model: modes must be 1 .. " + std::to_string(md.n_modes));
    if (o.residual_taps < 1 || o.residual_taps > m.length)
      throw InputError("modal model: residual taps must be 1 .. T");
    ModalModel out;
    static_cast<ModelFrame &>(out) = m;
    const unsigned M = o.modes, L = o.residual_taps, T = m.length, N = md.n_modes;
    const unsigned nin = m.n_inputs, nout = m.n_outputs;
    out.n_modes              = M;
    out.residual_taps        = L;
    out.highest_frequency_hz = md.frequency_hz[M - 1];
    out.shapes.resize(static_cast<size_t>(nout) * M);
    for (unsigned j = 0; j < nout; ++j)
      for (unsigned i = 0; i < M; ++i)
        out.shapes[static_cast<size_t>(j) * M + i] = md.shapes[static_cast<size_t>(j) * N + i];
    out.input_shapes.resize(static_cast<size_t>(nin) * M);
    for (unsigned k = 0; k < nin; ++k)
      {
        const unsigned j = 3 * m.input_output_index[k / 3] + k % 3;
        std::copy_n(&out.shapes[static_cast<size_t>(j) * M], M, &out.input_shapes[static_cast<size_t>(k) * M]);
      }
    out.step.assign(md.step.begin(), md.step.begin() + 15 * M);

    // q_i[s] of the kept modes (iterating their steps from a unit force at s = 0) and their
    // tail sums from L - 1 to T - 1.
    std::vector<double> q(static_cast<size_t>(L) * M), tail(M, 0.0);
    for (unsigned i = 0; i < M; ++i)
      {
        const double *A = &out.step[15 * i];
        double        x[3] = {0, 0, 0}, f_old = 0;
        for (unsigned s = 0; s < T; ++s)
          {
            const double f_new = s == 0 ? 1.0 : 0.0, y[3] = {x[0], x[1], x[2]};
            for (int r = 0; r < 3; ++r)
              x[r] = A[5 * r] * y[0] + A[5 * r + 1] * y[1] + A[5 * r + 2] * y[2] +
                     A[5 * r + 3] * f_new + A[5 * r + 4] * f_old;
            f_old = f_new;
            if (s < L - 1)
              q[static_cast<size_t>(s) * M + i] = x[0];
            else
              tail[i] += x[0];
          }
        q[static_cast<size_t>(L - 1) * M + i] = tail[i];
      }
    // Residual taps: H's own taps (and tail sum) minus the kept modes'.
    out.residual.resize(static_cast<size_t>(nin) * L * nout);
    std::vector<double> h(static_cast<size_t>(L) * nout), w(M);
    for (unsigned k = 0; k < nin; ++k)
      {
        std::fill(h.begin(), h.end(), 0.0);
        for (unsigned s = 0; s < T; ++s)
          {
            double *row = &h[static_cast<size_t>(std::min(s, L - 1)) * nout];
            for (unsigned j = 0; j < nout; ++j)
              row[j] += m.h(k, s, j);
          }
        const double *pk = &out.input_shapes[static_cast<size_t>(k) * M];
        for (unsigned s = 0; s < L; ++s)
          {
            for (unsigned i = 0; i < M; ++i)
              w[i] = pk[i] * q[static_cast<size_t>(s) * M + i];
            for (unsigned j = 0; j < nout; ++j)
              {
                const double *pj  = &out.shapes[static_cast<size_t>(j) * M];
                double        sum = 0;
                for (unsigned i = 0; i < M; ++i)
                  sum += pj[i] * w[i];
                out.residual[(static_cast<size_t>(k) * L + s) * nout + j] =
                  static_cast<float>(h[static_cast<size_t>(s) * nout + j] - sum);
              }
          }
      }
    out.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }

  ModalInteraction::ModalInteraction(const ModalModel &model)
    : model_(model)
    , M_(model.n_modes)
    , L_(model.residual_taps)
  {
    x_.assign(3 * M_, 0.0);
    u_modal_.assign(M_, 0.0);
    free_.assign(3 * M_, 0.0);
    g_prev_.assign(M_, 0.0);
    history_.assign(static_cast<size_t>(model.n_inputs) * L_, 0.0);
    last_nonzero_.assign(model.n_inputs, -1);
    is_active_input_.assign(model.n_inputs, 0);
    active_inputs_.reserve(model.n_inputs);
  }

  bool
  ModalInteraction::can_touch(const int t) const
  {
    return detail::can_touch(model_, t);
  }

  // sum over s = 1 .. L - 1 of E[s] f[n - s] at output j (before this step's force).
  double
  ModalInteraction::residual_history(const unsigned j) const
  {
    double       sum  = 0;
    const size_t nout = model_.n_outputs;
    for (const unsigned k : active_inputs_)
      for (long long s = 1; s < L_ && s <= n_; ++s)
        sum += model_.residual[(static_cast<size_t>(k) * L_ + s) * nout + j] *
               history_[static_cast<size_t>(k) * L_ + (n_ - s) % L_];
    return sum;
  }

  bool
  ModalInteraction::step(const ProbeTarget *probes, const int P)
  {
    for (int p = 0; p < P; ++p)
      if (!can_touch(probes[p].triangle))
        return false;
    active_inputs_.erase(std::remove_if(active_inputs_.begin(), active_inputs_.end(),
                                        [&](const unsigned k) {
                                          const bool gone = n_ - last_nonzero_[k] >= L_;
                                          if (gone)
                                            {
                                              is_active_input_[k] = 0;
                                              std::fill_n(&history_[static_cast<size_t>(k) * L_], L_, 0.0);
                                            }
                                          return gone;
                                        }),
                         active_inputs_.end());
    for (const unsigned k : active_inputs_)
      history_[static_cast<size_t>(k) * L_ + n_ % L_] = 0.0;
    // The state this step reaches if its force is zero.
    for (unsigned i = 0; i < M_; ++i)
      {
        const double *A = &model_.step[15 * i];
        const double *x = &x_[3 * i];
        for (int r = 0; r < 3; ++r)
          free_[3 * i + r] = A[5 * r] * x[0] + A[5 * r + 1] * x[1] + A[5 * r + 2] * x[2] +
                             A[5 * r + 4] * g_prev_[i];
      }
    const size_t nout = model_.n_outputs;
    detail::ProbeResults res;
    detail::probe_step(
      model_, probes, P,
      [&](unsigned, const unsigned j) {
        const double *pj  = &model_.shapes[static_cast<size_t>(j) * M_];
        double        sum = 0;
        for (unsigned i = 0; i < M_; ++i)
          sum += pj[i] * free_[3 * i];
        return sum + residual_history(j);
      },
      [&](const unsigned k, const unsigned j) {
        const double *pj = &model_.shapes[static_cast<size_t>(j) * M_];
        const double *pk = &model_.input_shapes[static_cast<size_t>(k) * M_];
        double        h0 = 0;
        for (unsigned i = 0; i < M_; ++i)
          h0 += pj[i] * pk[i] * model_.step[15 * i + 3];
        return h0 + model_.residual[static_cast<size_t>(k) * L_ * nout + j];
      },
      [&](const unsigned k, const double f) {
        history_[static_cast<size_t>(k) * L_ + n_ % L_] += f;
        last_nonzero_[k] = n_;
        if (!is_active_input_[k])
          {
            is_active_input_[k] = 1;
            active_inputs_.push_back(k); // capacity reserved: never reallocates
          }
      },
      res);
    force_   = res.force;
    probe_u_ = res.displacement;
    active_  = res.active;
    // Modal force of this step, then the state.
    std::fill(g_prev_.begin(), g_prev_.end(), 0.0);
    for (const unsigned k : active_inputs_)
      {
        const double f = history_[static_cast<size_t>(k) * L_ + n_ % L_];
        if (f == 0)
          continue;
        const double *pk = &model_.input_shapes[static_cast<size_t>(k) * M_];
        for (unsigned i = 0; i < M_; ++i)
          g_prev_[i] += pk[i] * f;
      }
    for (unsigned i = 0; i < M_; ++i)
      for (int r = 0; r < 3; ++r)
        x_[3 * i + r] = free_[3 * i + r] + model_.step[15 * i + 5 * r + 3] * g_prev_[i];
    for (unsigned i = 0; i < M_; ++i)
      u_modal_[i] = x_[3 * i];
    ++n_;
    return true;
  }

  void
  ModalInteraction::surface_displacement(double *u) const
  {
    const size_t nout = model_.n_outputs;
    for (size_t j = 0; j < nout; ++j)
      {
        const double *pj  = &model_.shapes[j * M_];
        double        sum = 0;
        for (unsigned i = 0; i < M_; ++i)
          sum += pj[i] * u_modal_[i];
        u[j] = sum;
      }
    if (n_ == 0)
      return;
    const long long now = n_ - 1;
    for (const unsigned k : active_inputs_)
      for (long long s = 0; s < L_ && s <= now; ++s)
        {
          const double f = history_[static_cast<size_t>(k) * L_ + (now - s) % L_];
          if (f == 0)
            continue;
          const float *e = &model_.residual[(static_cast<size_t>(k) * L_ + s) * nout];
          for (size_t j = 0; j < nout; ++j)
            u[j] += e[j] * f;
        }
  }
} // namespace irdm
