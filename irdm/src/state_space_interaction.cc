#include <irdm/state_space_interaction.h>
#include <irdm_common/error.h>

#include <Eigen/Core>

#include <algorithm>

#include "probe_step.h"
#include "surface_product.h"
#include "vertex_contact_step.h"

namespace irdm
{
  StateSpaceInteraction::StateSpaceInteraction(const StateSpaceModel &model,
                                               const VertexContactOptions &planes)
    : model_(model)
  {
    if (model.n_inputs == 0 || model.n_outputs == 0 || model.order == 0)
      throw InputError("state-space model has no inputs, outputs or states");
    vertex_contact_.reset(model, planes);
    pushed_.resize(model.n_inputs);
    pushed_last_.resize(model.n_inputs);
    is_pushed_.resize(model.n_inputs);
    y_.resize(model.output_dimension);
    reset();
  }

  void
  StateSpaceInteraction::reset()
  {
    n_ = 0;
    x_.assign(model_.order, 0.0);
    x_last_.assign(model_.order, 0.0);
    f_.assign(model_.n_inputs, 0.0);
    f_last_.assign(model_.n_inputs, 0.0);
    std::fill(is_pushed_.begin(), is_pushed_.end(), 0);
    n_pushed_ = n_pushed_last_ = 0;
  }

  bool
  StateSpaceInteraction::can_touch(const int t) const
  {
    return detail::can_touch(model_, t);
  }

  bool
  StateSpaceInteraction::can_touch(const ProbeTarget &probe) const
  {
    return detail::can_touch(model_, probe);
  }

  namespace
  {
    // One output direction of a state: row dir of c (float) times x, summed in double.
    double
    direction_of(const StateSpaceModel &m, const size_t dir, const std::vector<double> &x)
    {
      const float *c   = &m.c[dir * m.order];
      double       sum = 0;
      for (unsigned i = 0; i < m.order; ++i)
        sum += static_cast<double>(c[i]) * x[i];
      return sum;
    }
  } // namespace

  double
  StateSpaceInteraction::history(const unsigned k) const
  {
    return direction_of(model_, model_.contact_direction[k], x_);
  }

  void
  StateSpaceInteraction::push(const unsigned k, const double f)
  {
    if (!is_pushed_[k])
      {
        is_pushed_[k]         = 1;
        pushed_[n_pushed_++] = k;
      }
    f_[k] += f;
  }

  // x[n + 1] = A x[n] + B f[n], written over the buffer of x[n - 1]; then the buffers turn
  // so that x_last_, f_last_ hold step n for the surface update.
  void
  StateSpaceInteraction::advance()
  {
    const unsigned nr = model_.n_real, r = model_.order;
    double        *xn = x_last_.data();
    const double  *x  = x_.data();
    for (unsigned i = 0; i < nr; ++i)
      xn[i] = model_.real_poles[i] * x[i];
    for (unsigned p = 0, i = nr; p < model_.n_pairs(); ++p, i += 2)
      {
        const double a = model_.complex_poles[2 * p], b = model_.complex_poles[2 * p + 1];
        xn[i]          = a * x[i] + b * x[i + 1];
        xn[i + 1]      = -b * x[i] + a * x[i + 1];
      }
    Eigen::Map<Eigen::VectorXd> next(xn, r);
    for (unsigned q = 0; q < n_pushed_; ++q)
      {
        const unsigned k = pushed_[q];
        next += f_[k] * Eigen::Map<const Eigen::VectorXd>(&model_.b[static_cast<size_t>(k) * r], r);
        is_pushed_[k] = 0;
      }
    x_.swap(x_last_);
    for (unsigned q = 0; q < n_pushed_last_; ++q)
      f_last_[pushed_last_[q]] = 0;
    f_.swap(f_last_);
    pushed_.swap(pushed_last_);
    n_pushed_last_ = n_pushed_;
    n_pushed_      = 0;
  }

  bool
  StateSpaceInteraction::step(const ProbeTarget *probes, const int P)
  {
    for (int p = 0; p < P; ++p)
      if (!can_touch(probes[p]))
        return false;
    const unsigned nout = model_.n_outputs;
    detail::probe_step(
      model_, probes, P, [&](const unsigned i, unsigned) { return history(i); },
      [&](const unsigned k, const unsigned j) { return model_.d[static_cast<size_t>(k) * nout + j]; },
      [&](const unsigned k, const double f) { push(k, f); }, results_);
    advance();
    ++n_;
    return true;
  }

  bool
  StateSpaceInteraction::step(const PlaneTarget *planes, const int n_planes)
  {
    const unsigned nout = model_.n_outputs;
    const bool     ok   = vertex_contact_.step(
      model_, planes, n_planes,
      [&](const unsigned vi, unsigned, const std::array<double, 3> &n, int, bool) {
        return n[0] * history(3 * vi) + n[1] * history(3 * vi + 1) + n[2] * history(3 * vi + 2);
      },
      [&](const unsigned k, const unsigned j) { return model_.d[static_cast<size_t>(k) * nout + j]; },
      [&](const unsigned k, const double f) { push(k, f); });
    if (!ok)
      return false;
    advance();
    ++n_;
    return true;
  }

  void
  StateSpaceInteraction::surface_displacement(double *u) const
  {
    const unsigned nout = model_.n_outputs;
    Eigen::Map<Eigen::VectorXd> out(u, nout);
    if (n_ == 0)
      {
        out.setZero();
        return;
      }
    // y = c x (every direction), then u = basis y: float rows through the modal surface
    // update's kernel (vectorized, summing in float where the CPU has AVX2: where c x cancels,
    // its rounding is relative to the terms, not the sum). The force loop's contact rows
    // (history) keep their double sums, so the surface there differs from them by that rounding.
    const unsigned ro = model_.output_dimension;
    double        *y  = model_.output_basis.empty() ? u : y_.data();
    detail::surface_product(model_.c.data(), model_.order, ro, x_last_.data(), y);
    if (!model_.output_basis.empty())
      detail::surface_product(model_.output_basis.data(), ro, nout, y, u);
    for (unsigned q = 0; q < n_pushed_last_; ++q)
      {
        const unsigned k = pushed_last_[q];
        out += f_last_[k] * Eigen::Map<const Eigen::VectorXd>(&model_.d[static_cast<size_t>(k) * nout], nout);
      }
  }
} // namespace irdm
