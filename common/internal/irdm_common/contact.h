#pragma once
// The contact solve of IRDM point interaction (seed 000, section 2; method note section 3),
// shared by the reference FEM and the IRDM runtime so that both take the same decisions.
//
// Each probe p constrains 3 components. With lambda the contact forces on the body (N), the
// probe points move as  u = u_free + S lambda,  S the (3P x 3P) compliance of the current step
// (FEM: B K_eff^{-1} B^T; IRDM: B H[0] B^T). Prescribing u = g gives S lambda = g - u_free.
// A unilateral probe pushes along its direction d and never pulls: it is active when the free
// surface would pass it (d . (g - u_free) > 0) and is dropped while d . lambda < 0 (active set,
// most-pulling probe first). Fixed-size Eigen types: no heap allocation on the haptic path.
#include <Eigen/Dense>

#include <array>

namespace irdm::contact
{
  constexpr int max_probes = 4;
  // Vertices one probe's force may spread over (a probe with a contact radius; a point probe
  // spreads over the 3 vertices of its triangle). 256 holds a 2 cm radius on the converged
  // P1 cat (lc 3.4 mm: 139 vertices, reports/converged/).
  constexpr int max_patch = 256;
  constexpr int max_rows   = 3 * max_probes;
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, max_rows, max_rows>;
  using Vector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, max_rows, 1>;

  /// Virtual coupling (Colgate et al. 1995): a spring (stiffness, N/m) and a damper
  /// (damping, N s/m) between the device and the probed surface point, in place of a rigid
  /// probe. Discretized implicitly: with u the point's displacement this step, u_prev the last
  /// step's, x the device's displacement and v its velocity, the force on the body is
  ///   f = k (x - u) + b (v - (u - u_prev) / tau) = c (z - u),   c = k + b / tau,
  ///   z = (k x + b v + (b / tau) u_prev) / c,
  /// that is, a prescribed displacement z behind the compliance 1 / c in series: S + I / c
  /// in the contact solve. So the spring is stiff only through the body's own feed-through and
  /// cannot make the step explicit; a unilateral probe is decided on this coupled force. Both
  /// zero: the rigid probe (the seeds' limit).
  struct Coupling
  {
    double stiffness = 0; // N/m
    double damping   = 0; // N s/m

    bool
    rigid() const
    {
      return !(stiffness > 0 || damping > 0);
    }
    /// 1 / c (m/N); 0 for the rigid probe.
    double
    compliance(const double tau) const
    {
      return rigid() ? 0.0 : 1.0 / (stiffness + damping / tau);
    }
    /// z (m) from the device's displacement now and one step before (its velocity by the
    /// same backward difference) and the point's displacement one step before.
    std::array<double, 3>
    target(const std::array<double, 3> &device, const std::array<double, 3> &device_prev,
           const std::array<double, 3> &u_prev, const double tau) const
    {
      if (rigid())
        return device;
      const double          c = stiffness + damping / tau;
      std::array<double, 3> z;
      for (int d = 0; d < 3; ++d)
        z[d] = (stiffness * device[d] + damping * (device[d] - device_prev[d]) / tau +
                damping / tau * u_prev[d]) / c;
      return z;
    }
  };

  struct ProbeRule
  {
    std::array<double, 3> direction  = {0, 0, -1};
    bool                  unilateral = false;
    bool                  present    = true; // false: the probe has let go for good
  };

  /// Solves for lambda (3P; zero on inactive probes) and sets active[p]. Returns the number
  /// of active probes.
  inline int
  solve_active_set(const Matrix &S, const Vector &gap, const ProbeRule *rules, const int P,
                   Vector &lambda, bool *active)
  {
    const auto along = [&](const Vector &x, const int p) {
      return rules[p].direction[0] * x[3 * p] + rules[p].direction[1] * x[3 * p + 1] +
             rules[p].direction[2] * x[3 * p + 2];
    };
    for (int p = 0; p < P; ++p)
      active[p] = rules[p].present && (!rules[p].unilateral || along(gap, p) > 0);
    lambda.setZero(3 * P);
    for (int iteration = 0; iteration <= P; ++iteration)
      {
        std::array<int, max_rows> rows{};
        int                       n = 0;
        for (int p = 0; p < P; ++p)
          if (active[p])
            for (int d = 0; d < 3; ++d)
              rows[n++] = 3 * p + d;
        lambda.setZero(3 * P);
        if (n == 0)
          return 0;
        Matrix Sa(n, n);
        Vector ra(n);
        for (int i = 0; i < n; ++i)
          {
            ra[i] = gap[rows[i]];
            for (int j = 0; j < n; ++j)
              Sa(i, j) = S(rows[i], rows[j]);
          }
        const Vector la = Sa.partialPivLu().solve(ra);
        for (int i = 0; i < n; ++i)
          lambda[rows[i]] = la[i];
        int    worst = -1;
        double most  = 0;
        for (int p = 0; p < P; ++p)
          if (active[p] && rules[p].unilateral && along(lambda, p) < most)
            {
              most  = along(lambda, p);
              worst = p;
            }
        if (worst < 0)
          return n / 3;
        active[worst] = false;
      }
    return 0; // not reached: each iteration drops one probe
  }
} // namespace irdm::contact
