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
// none where a unilateral coupling would pull. A fixed-size 3 x 3 solve: no allocation, no lock.
#include <Eigen/Dense>

#include <array>

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
    using V = Eigen::Vector3d;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> W(c.W.data());
    const Eigen::Map<const V> u(c.u.data()), v(c.v.data()), a(c.a.data()), f_k(c.f.data()),
      d(g.d.data()), d_dot(g.d_dot.data()), n(g.direction.data());
    const double    k = g.stiffness, s = t - c.time;
    const V         y = k * (d - u - v * s - 0.5 * s * s * a + W * f_k) + g.damping * (d_dot - v - s * a);
    // I + k W, with W symmetric positive semi-definite: symmetric positive definite.
    const V f = (Eigen::Matrix3d::Identity() + k * W).ldlt().solve(y);
    if (g.unilateral && f.dot(n) <= 0)
      return {0, 0, 0};
    return {f(0), f(1), f(2)};
  }
} // namespace irdm
