#include <irdm/point_interaction.h>
#include <irdm_common/error.h>

#include "probe_step.h"
#include "vertex_contact_step.h"

#include <algorithm>

namespace irdm
{
  PointInteraction::PointInteraction(const ImpulseResponseModel &model, const unsigned taps,
                                     const VertexContactOptions &planes)
    : model_(model)
    , taps_(taps == 0 ? model.length : std::min(taps, model.length))
  {
    if (model.n_inputs == 0 || model.n_outputs == 0)
      throw InputError("model has no inputs or outputs");
    history_.reset(model.n_inputs, taps_, taps_);
    vertex_contact_.reset(model, planes);
    const size_t n = model.n_inputs;
    if (n * n * taps_ * sizeof(double) <= (size_t(256) << 20))
      {
        h_cc_.resize(n * n * taps_);
        for (size_t k = 0; k < n; ++k)
          for (size_t i = 0; i < n; ++i)
            {
              const unsigned j = 3 * model.input_output_index[i / 3] + i % 3;
              for (size_t s = 0; s < taps_; ++s)
                h_cc_[(k * n + i) * taps_ + s] = model.h(k, s, j);
            }
      }
  }

  double
  PointInteraction::history_row(const unsigned i, const unsigned j) const
  {
    return !h_cc_.empty()           ? history_at_contact(i)
           : model_.double_storage ? history_at(model_.h_double.data(), j)
                                    : history_at(model_.h_float.data(), j);
  }

  // As history_at, from the contiguous H_CC block.
  double
  PointInteraction::history_at_contact(const unsigned i) const
  {
    const size_t    n    = model_.n_inputs;
    const long long smax = std::min<long long>(taps_ - 1, n_);
    double          sum  = 0;
    for (const unsigned k : history_.active())
      {
        const double *f = history_.row(k);
        const double *h = &h_cc_[(k * n + i) * taps_];
        // s = 1 .. smax reads slots (n_ - s) mod taps: two contiguous runs, walked backwards.
        const long long first = (n_ - 1) % taps_; // slot of s = 1
        const long long run1  = std::min<long long>(smax, first + 1);
        for (long long s = 1; s <= run1; ++s)
          sum += h[s] * f[first - (s - 1)];
        const long long top = taps_ - 1;
        for (long long s = run1 + 1; s <= smax; ++s)
          sum += h[s] * f[top - (s - run1 - 1)];
      }
    return sum;
  }

  void
  PointInteraction::reset()
  {
    n_ = 0;
    history_.reset(model_.n_inputs, taps_, taps_);
  }

  bool
  PointInteraction::can_touch(const int t) const
  {
    return detail::can_touch(model_, t);
  }

  bool
  PointInteraction::can_touch(const ProbeTarget &probe) const
  {
    return detail::can_touch(model_, probe);
  }

  // sum over active inputs k and s = 1 .. taps-1 of H[k][s][j] f_k[n - s], at the current
  // step n_ (before its force is known).
  template <typename Scalar>
  double
  PointInteraction::history_at(const Scalar *H, const unsigned j) const
  {
    double         sum  = 0;
    const unsigned T    = model_.length;
    const size_t   nout = model_.n_outputs;
    const long long smax = std::min<long long>(taps_ - 1, n_);
    for (const unsigned k : history_.active())
      {
        const double *f   = history_.row(k);
        const Scalar *hk  = H + static_cast<size_t>(k) * T * nout + j;
        for (long long s = 1; s <= smax; ++s)
          sum += static_cast<double>(hk[s * nout]) * f[(n_ - s) % taps_];
      }
    return sum;
  }

  bool
  PointInteraction::step(const ProbeTarget *probes, const int P)
  {
    for (int p = 0; p < P; ++p)
      if (!can_touch(probes[p]))
        return false;
    history_.begin_step(n_, [](unsigned) {});
    detail::probe_step(
      model_, probes, P,
      [&](const unsigned i, const unsigned j) { return history_row(i, j); },
      [&](const unsigned k, const unsigned j) { return model_.h(k, 0, j); },
      [&](const unsigned k, const double f) { history_.push(k, n_, f); },
      results_);
    ++n_;
    return true;
  }

  bool
  PointInteraction::step(const PlaneTarget *planes, const int n_planes)
  {
    history_.begin_step(n_, [](unsigned) {});
    const bool ok = vertex_contact_.step(
      model_, planes, n_planes,
      [&](const unsigned vi, const unsigned vo, const std::array<double, 3> &n, int, bool) {
        return n[0] * history_row(3 * vi, 3 * vo) + n[1] * history_row(3 * vi + 1, 3 * vo + 1) +
               n[2] * history_row(3 * vi + 2, 3 * vo + 2);
      },
      [&](const unsigned k, const unsigned j) { return model_.h(k, 0, j); },
      [&](const unsigned k, const double f) { history_.push(k, n_, f); });
    if (ok)
      ++n_;
    return ok;
  }

  template <typename Scalar>
  void
  PointInteraction::surface_kernel(const Scalar *H, double *u) const
  {
    const size_t    nout = model_.n_outputs;
    const long long now  = n_ - 1; // the last step taken
    std::fill(u, u + nout, 0.0);
    if (now < 0)
      return;
    const long long smax = std::min<long long>(taps_ - 1, now);
    for (const unsigned k : history_.active())
      {
        const double *f  = history_.row(k);
        const Scalar *hk = H + static_cast<size_t>(k) * model_.length * nout;
        for (long long s = 0; s <= smax; ++s)
          {
            const double c = f[(now - s) % taps_];
            if (c == 0)
              continue;
            const Scalar *row = hk + s * nout;
            for (size_t j = 0; j < nout; ++j)
              u[j] += c * static_cast<double>(row[j]);
          }
      }
  }

  void
  PointInteraction::surface_displacement(double *u) const
  {
    if (model_.double_storage)
      surface_kernel(model_.h_double.data(), u);
    else
      surface_kernel(model_.h_float.data(), u);
  }
} // namespace irdm
