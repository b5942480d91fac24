#include <irdm/representative_interaction.h>
#include <irdm_common/error.h>

#include <algorithm>

#include "probe_step.h"

namespace irdm
{
  RepresentativeInteraction::RepresentativeInteraction(const RepresentativeModel &model)
    : model_(model)
    , T_(model.length)
    , ring_(model.delay_span + 1)
  {
    if (model.n_inputs == 0 || model.n_outputs == 0)
      throw InputError("model has no inputs or outputs");
    const size_t R = model.n_representative();
    term_offset_.resize(model.term_amplitude.size());
    const size_t per_input = static_cast<size_t>(model.n_outputs) * model.blend;
    if (2 * R * ring_ >= (size_t(1) << 32))
      throw InputError("compressed model too large for 32-bit ring offsets");
    for (size_t t = 0; t < term_offset_.size(); ++t)
      {
        const size_t row = model.first_representative[t / per_input] + model.term_representative[t];
        term_offset_[t]  = static_cast<std::uint32_t>(row * 2 * ring_ + ring_ - model.term_delay[t]);
      }
    // An input stays active while its convolutions or their delayed reads can be nonzero.
    history_.reset(model.n_inputs, T_, static_cast<long long>(T_) + ring_);
    partial_.assign(R, 0.0);
    c_.assign(R * 2 * ring_, 0.0);
  }

  bool
  RepresentativeInteraction::can_touch(const int t) const
  {
    return detail::can_touch(model_, t);
  }

  bool
  RepresentativeInteraction::can_touch(const ProbeTarget &probe) const
  {
    return detail::can_touch(model_, probe);
  }

  double
  RepresentativeInteraction::feed_through(const unsigned k, const unsigned j) const
  {
    const size_t base = (static_cast<size_t>(k) * model_.n_outputs + j) * model_.blend;
    double       h0   = 0;
    for (unsigned b = 0; b < model_.blend; ++b)
      if (model_.term_delay[base + b] == 0 && model_.term_amplitude[base + b] != 0)
        h0 += static_cast<double>(model_.term_amplitude[base + b]) *
              model_.representatives[(model_.first_representative[k] + model_.term_representative[base + b]) * T_];
    return h0;
  }

  // Displacement of output j from the forces of earlier steps, at the current step n_.
  double
  RepresentativeInteraction::history_at(const unsigned j) const
  {
    const unsigned slot = static_cast<unsigned>(n_ % ring_);
    double         sum  = 0;
    for (const unsigned k : history_.active())
      {
        const size_t base = (static_cast<size_t>(k) * model_.n_outputs + j) * model_.blend;
        for (unsigned b = 0; b < model_.blend; ++b)
          {
            const double a = model_.term_amplitude[base + b];
            if (a == 0)
              continue;
            if (model_.term_delay[base + b] == 0)
              sum += a * partial_[model_.first_representative[k] + model_.term_representative[base + b]];
            else // c_r[n - d], d >= 1: written in an earlier step
              sum += a * c_[term_offset_[base + b] + slot];
          }
      }
    return sum;
  }

  bool
  RepresentativeInteraction::step(const ProbeTarget *probes, const int P)
  {
    for (int p = 0; p < P; ++p)
      if (!can_touch(probes[p]))
        return false;
    history_.begin_step(n_, [&](const unsigned k) {
      for (auto r = model_.first_representative[k]; r < model_.first_representative[k + 1]; ++r)
        {
          partial_[r] = 0;
          std::fill_n(&c_[r * 2 * ring_], 2 * ring_, 0.0);
        }
    });
    // p_r for every representative of every active input (this step's force slot cleared).
    const long long first = (n_ + T_ - 1) % T_; // slot of s = 1
    const long long smax  = std::min<long long>(T_ - 1, n_);
    const long long run1  = std::min<long long>(smax, first + 1);
    for (const unsigned k : history_.active())
      {
        const double *f = history_.row(k);
        for (auto r = model_.first_representative[k]; r < model_.first_representative[k + 1]; ++r)
          {
            const float  *h   = &model_.representatives[r * T_];
            double        sum = 0;
            for (long long s = 1; s <= run1; ++s)
              sum += static_cast<double>(h[s]) * f[first - (s - 1)];
            for (long long s = run1 + 1; s <= smax; ++s)
              sum += static_cast<double>(h[s]) * f[T_ - 1 - (s - run1 - 1)];
            partial_[r] = sum;
          }
      }

    detail::probe_step(
      model_, probes, P, [&](unsigned, const unsigned j) { return history_at(j); },
      [&](const unsigned k, const unsigned j) { return feed_through(k, j); },
      [&](const unsigned k, const double f) { history_.push(k, n_, f); },
      results_);

    // c_r[n] = p_r + r[0] f_k[n], written at both copies of the ring slot.
    const unsigned slot = static_cast<unsigned>(n_ % ring_);
    for (const unsigned k : history_.active())
      {
        const double f = history_.row(k)[n_ % T_];
        for (auto r = model_.first_representative[k]; r < model_.first_representative[k + 1]; ++r)
          {
            const double c = partial_[r] + static_cast<double>(model_.representatives[r * T_]) * f;
            c_[r * 2 * ring_ + slot] = c_[r * 2 * ring_ + slot + ring_] = c;
          }
      }
    ++n_;
    return true;
  }

  void
  RepresentativeInteraction::surface_displacement(double *u) const
  {
    const size_t nout = model_.n_outputs, B = model_.blend;
    std::fill(u, u + nout, 0.0);
    if (n_ == 0)
      return;
    const unsigned slot = static_cast<unsigned>((n_ - 1) % ring_); // the last step taken
    const double  *c    = c_.data() + slot;
    for (const unsigned k : history_.active())
      {
        const float         *a   = &model_.term_amplitude[k * nout * B];
        const std::uint32_t *off = &term_offset_[k * nout * B];
        if (B == 1)
          for (size_t j = 0; j < nout; ++j)
            u[j] += a[j] * c[off[j]];
        else
          for (size_t j = 0; j < nout; ++j)
            for (size_t b = 0; b < B; ++b)
              u[j] += a[j * B + b] * c[off[j * B + b]];
      }
  }
} // namespace irdm
