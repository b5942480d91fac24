#pragma once
// The force loop of a reduced nonlinear body's two loops (issue 50; docs/reduced-model.md): the
// seed's split, with the deformation loop taking the Newton step and the force loop, at the
// haptic rate, working on the compliance of the latest deformation state.
//
// After each deformation step the deformation loop publishes, for the probed point, a
// LocalCompliance: the point's displacement u_k, velocity v_k and acceleration a_k at t_k, its
// compliance W over one step (ReducedNonlinearBody::point_state) and the force f_k the step was
// taken with. The force loop predicts the point at a later time t, s = t - t_k, as the state
// moving on at its acceleration under the same force (Newmark's own answer to an unchanged
// force where inertia rules), plus the compliance's answer to the change of force:
//   u(t) = u_k + v_k s + a_k s^2 / 2 + W (f - f_k),
// and solves the virtual coupling's force against it, f = k (d - u(t)) + b (d' - v_k - a_k s):
//   (I + k W) f = k (d - u_k - v_k s - a_k s^2 / 2 + W f_k) + b (d' - v_k - a_k s),
// none where a unilateral coupling would pull. A 3 x 3 solve: no allocation, no lock.
#include <array>
#include <cmath>

namespace irdm
{
  struct LocalCompliance
  {
    long long             step = -1; // deformation steps taken at this state (-1: none yet)
    double                time = 0;  // s
    std::array<double, 3> u{}, v{}, a{}; // the point's displacement (m), velocity, acceleration
    std::array<double, 9> W{};       // m/N, row-major
    std::array<double, 3> f{};       // N: the force the state was stepped with
  };

  struct CouplingTarget
  {
    std::array<double, 3> d{}, d_dot{};   // the device's displacement (m) and velocity (m/s)
    double                stiffness = 0;  // N/m (> 0)
    double                damping   = 0;  // N s/m
    std::array<double, 3> direction{0, 0, -1};
    bool                  unilateral = false;
  };

  /// The coupling's force on the body at time t (s) against the state c (N).
  inline std::array<double, 3>
  coupling_force(const LocalCompliance &c, const double t, const CouplingTarget &g)
  {
    const double k = g.stiffness, s = t - c.time;
    double       A[3][3], y[3];
    for (int i = 0; i < 3; ++i)
      {
        double Wf = 0;
        for (int j = 0; j < 3; ++j)
          {
            A[i][j] = (i == j) + k * c.W[3 * i + j];
            Wf += c.W[3 * i + j] * c.f[j];
          }
        y[i] = k * (g.d[i] - c.u[i] - c.v[i] * s - 0.5 * c.a[i] * s * s + Wf) +
               g.damping * (g.d_dot[i] - c.v[i] - c.a[i] * s);
      }
    // Cramer's rule: A is I + k W with W symmetric positive semi-definite, never singular.
    const double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                       A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                       A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    std::array<double, 3> f{};
    for (int col = 0; col < 3; ++col)
      {
        double B[3][3];
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            B[i][j] = j == col ? y[i] : A[i][j];
        f[col] = (B[0][0] * (B[1][1] * B[2][2] - B[1][2] * B[2][1]) -
                  B[0][1] * (B[1][0] * B[2][2] - B[1][2] * B[2][0]) +
                  B[0][2] * (B[1][0] * B[2][1] - B[1][1] * B[2][0])) /
                 det;
      }
    if (g.unilateral && f[0] * g.direction[0] + f[1] * g.direction[1] + f[2] * g.direction[2] <= 0)
      f = {0, 0, 0};
    return f;
  }
} // namespace irdm
