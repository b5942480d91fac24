#pragma once
// Unilateral contact at many points (issue 13), shared by the reference FEM and the IRDM
// runtime so that both take the same decisions: the linear complementarity problem
//   g = W lambda + q,   lambda >= 0,   g >= 0,   lambda_i g_i = 0,
// lambda the normal contact forces (N), g the gaps after the step (m), q the gaps the step
// would reach with no contact force, and W the contact rows' feed-through (m/N: N^T H[0] N in
// IRDM, N^T K_eff^{-1} N in the FEM), plus 1/k on the diagonal for a compliant wall of
// stiffness k (the wall's force k * penetration, solved implicitly). W is symmetric positive
// definite, so the solution exists and is unique.
//
// Method: block principal pivoting (Judice and Pires, Comput. Oper. Res. 21, 1994): guess the
// active set A, solve W_AA lambda_A = -q_A (Cholesky), and swap every row that violates
// lambda >= 0 (in A) or g >= 0 (outside A). When the number of violating rows has not fallen
// for 3 rounds in a row, swap only the violating row of largest index (Murty's rule), which
// terminates for any P-matrix. The result is exact to round-off, not to a tolerance. Warm-
// started from the previous step's active set, a step whose contact changes little takes one
// or two rounds (each one Cholesky of the active rows).
//
// Stopping rule: a row violates if lambda_i < -tol * max|lambda| or g_i < -tol * max|q|, with
// tol = 1e-12 (round-off, not a physical tolerance). Memory is sized by reserve(); solve()
// allocates nothing.
#include <algorithm>
#include <cmath>
#include <vector>

namespace irdm::contact
{
  class ComplementaritySolver
  {
  public:
    static constexpr double tolerance = 1e-12;

    explicit ComplementaritySolver(const int capacity = 0)
    {
      reserve(capacity);
    }

    /// Room for problems of up to `capacity` rows (allocates).
    void
    reserve(const int capacity)
    {
      capacity_ = std::max(capacity, 0);
      factor_.assign(static_cast<size_t>(capacity_) * capacity_, 0.0);
      rhs_.assign(capacity_, 0.0);
      gap_.assign(capacity_, 0.0);
      rows_.assign(capacity_, 0);
    }
    int
    capacity() const
    {
      return capacity_;
    }

    /// Solves the problem of n <= capacity() rows. W is n x n, row-major with row stride ldw
    /// (only its lower triangle is read: W must be symmetric). active: in, the guess (1 =
    /// in contact); out, the active set. lambda: out, the forces (0 off the active set).
    /// Returns the number of rounds (>= 1), or -1 if W is not positive definite on the active
    /// rows or the rounds exceed 10 n + 20 (neither happens for a symmetric positive definite
    /// W; a guard against bad data). g(), after a solve: the gaps W lambda + q.
    int
    solve(const int n, const double *W, const int ldw, const double *q, char *active,
          double *lambda)
    {
      if (n > capacity_ || n < 0)
        return -1;
      const auto w = [&](const int i, const int j) {
        return i >= j ? W[static_cast<size_t>(i) * ldw + j] : W[static_cast<size_t>(j) * ldw + i];
      };
      double q_scale = 0;
      for (int i = 0; i < n; ++i)
        q_scale = std::max(q_scale, std::abs(q[i]));
      int       best_violations = n + 1, patience = 3;
      const int max_rounds      = 10 * n + 20;
      for (int round = 1; round <= max_rounds; ++round)
        {
          // lambda_A = -W_AA^{-1} q_A by Cholesky of W_AA (lower, row-major, stride capacity_).
          int m = 0;
          for (int i = 0; i < n; ++i)
            if (active[i])
              rows_[m++] = i;
          double *L = factor_.data();
          for (int a = 0; a < m; ++a)
            {
              for (int b = 0; b <= a; ++b)
                {
                  double s = w(rows_[a], rows_[b]);
                  for (int c = 0; c < b; ++c)
                    s -= L[a * capacity_ + c] * L[b * capacity_ + c];
                  if (a == b)
                    {
                      if (!(s > 0))
                        return -1;
                      L[a * capacity_ + a] = std::sqrt(s);
                    }
                  else
                    L[a * capacity_ + b] = s / L[b * capacity_ + b];
                }
            }
          for (int a = 0; a < m; ++a) // forward: L y = -q_A
            {
              double s = -q[rows_[a]];
              for (int c = 0; c < a; ++c)
                s -= L[a * capacity_ + c] * rhs_[c];
              rhs_[a] = s / L[a * capacity_ + a];
            }
          for (int a = m - 1; a >= 0; --a) // back: L^T x = y
            {
              double s = rhs_[a];
              for (int c = a + 1; c < m; ++c)
                s -= L[c * capacity_ + a] * rhs_[c];
              rhs_[a] = s / L[a * capacity_ + a];
            }
          std::fill(lambda, lambda + n, 0.0);
          double lambda_scale = 0;
          for (int a = 0; a < m; ++a)
            {
              lambda[rows_[a]] = rhs_[a];
              lambda_scale     = std::max(lambda_scale, std::abs(rhs_[a]));
            }
          for (int i = 0; i < n; ++i)
            {
              double s = q[i];
              for (int a = 0; a < m; ++a)
                s += w(i, rows_[a]) * rhs_[a];
              gap_[i] = s;
            }
          // Rows that violate: a pulling contact force, or a gap below zero off contact.
          int violations = 0, last = -1;
          for (int i = 0; i < n; ++i)
            if (active[i] ? lambda[i] < -tolerance * lambda_scale
                          : gap_[i] < -tolerance * q_scale)
              {
                ++violations;
                last = i;
              }
          if (violations == 0)
            {
              for (int i = 0; i < n; ++i)
                if (active[i] && lambda[i] < 0)
                  lambda[i] = 0; // round-off below the rule's tolerance
              return round;
            }
          if (violations < best_violations)
            {
              best_violations = violations;
              patience        = 3;
            }
          else if (patience > 0)
            --patience;
          else
            {
              active[last] = !active[last]; // Murty's rule: one row, the last
              continue;
            }
          for (int i = 0; i < n; ++i)
            if (active[i] ? lambda[i] < -tolerance * lambda_scale
                          : gap_[i] < -tolerance * q_scale)
              active[i] = !active[i];
        }
      return -1;
    }

    /// The gaps W lambda + q of the latest solve (m), row i.
    double
    g(const int i) const
    {
      return gap_[i];
    }

  private:
    int                 capacity_ = 0;
    std::vector<double> factor_, rhs_, gap_;
    std::vector<int>    rows_;
  };

  /// The fallback when solve() refuses (W not positive definite, or more rounds than it
  /// allows): projected Gauss-Seidel, `sweeps` sweeps from lambda as given, each row in turn
  /// lambda_i = max(0, lambda_i - g_i / W_ii). For a positive definite W it converges to the
  /// solution (monotonically in the LCP's energy) but not in a bounded number of sweeps, so the
  /// result is approximate; it needs only W_ii > 0 (a row with W_ii <= 0 keeps lambda_i = 0).
  /// W: lower triangle, row-major, stride ldw (as solve()). Writes the gaps W lambda + q to g.
  /// Allocates nothing.
  inline void
  projected_gauss_seidel(const int n, const double *W, const int ldw, const double *q,
                         double *lambda, const int sweeps, double *g)
  {
    const auto w = [&](const int i, const int j) {
      return i >= j ? W[static_cast<size_t>(i) * ldw + j] : W[static_cast<size_t>(j) * ldw + i];
    };
    const auto gap = [&](const int i) {
      double s = q[i];
      for (int j = 0; j < n; ++j)
        s += w(i, j) * lambda[j];
      return s;
    };
    for (int i = 0; i < n; ++i)
      if (!(lambda[i] > 0) || !(w(i, i) > 0))
        lambda[i] = 0;
    for (int sweep = 0; sweep < sweeps; ++sweep)
      for (int i = 0; i < n; ++i)
        if (w(i, i) > 0)
          lambda[i] = std::max(0.0, lambda[i] - gap(i) / w(i, i));
    for (int i = 0; i < n; ++i)
      g[i] = gap(i);
  }
} // namespace irdm::contact
