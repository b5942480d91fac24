#pragma once
// Internal to validation/: the error measures every study reports, defined once. A method's run
// (test) against a reference run (truth), sample by sample over a history.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace irdm::validation
{
  /// Relative L2 error of a history: sqrt(sum |test - truth|^2 / sum |truth|^2) over every
  /// sample added (and every component of a sample). A zero truth gives sqrt(e2 / 1e-300).
  class RelativeL2
  {
  public:
    void
    add(const double test, const double truth)
    {
      e2_ += (test - truth) * (test - truth);
      n2_ += truth * truth;
    }

    /// One sample of many components (a surface's displacement).
    void
    add(const std::vector<double> &test, const std::vector<double> &truth)
    {
      for (std::size_t i = 0; i < test.size(); ++i)
        add(test[i], truth[i]);
    }

    /// The squared norms, for windows of a history summed apart.
    void
    add_squared(const double error2, const double truth2)
    {
      e2_ += error2;
      n2_ += truth2;
    }

    double
    value() const
    {
      return std::sqrt(e2_ / std::max(n2_, 1e-300));
    }

  private:
    double e2_ = 0, n2_ = 0;
  };

  /// Impulse error: |sum test - sum truth| / |sum truth| of a force history along one direction.
  /// Unlike the L2 error it is not scrambled by contact that bounces (chatter at one vertex).
  class ImpulseError
  {
  public:
    void
    add(const double test, const double truth)
    {
      test_ += test;
      truth_ += truth;
    }

    double
    value() const
    {
      return std::abs(test_ - truth_) / std::max(truth_, 1e-300);
    }

  private:
    double test_ = 0, truth_ = 0;
  };
} // namespace irdm::validation
