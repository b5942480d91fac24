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
// force where inertia rules), plus the compliance's answer to the change of force and the
// answer m (u_m, v_m: below; zero in lockstep) to the forces since the state:
//   u(t) = u_k + v_k s + a_k s^2 / 2 + u_m + W (f - f_k),
// and solves the virtual coupling's force against it, f = k (d - u(t)) + b (d' - v_k - a_k s - v_m):
//   (I + k W) f = k (d - u_k - v_k s - a_k s^2 / 2 - u_m + W f_k) + b (d' - v_k - a_k s - v_m),
// none where a unilateral coupling would pull. A fixed-size 3 x 3 solve: no allocation, no lock.
//
// A deformation loop that falls behind leaves the force loop on a state older than the window
// before the present one: the forces of the windows in between (g_i, the means the deformation
// loop steps with) have moved the body, and the state does not hold it. The force loop then
// adds their answer, each change g_i - f_k as a force held over its window alone, through the
// point's impulse response by inertia alone: m windows later, H_m = c_m W in displacement and
// e_m W / tau in velocity, c_m and e_m the integrator's own for a free unit mass
// (inertial_lag_response); u_m and v_m are their sums. One step behind (one window between)
// that is exact where inertia rules the point over the lag; the body's stiffness and damping,
// left out, would make the true answer smaller. Answering more windows than
// InertialLagResponse::windows, with the prediction held further, did worse on the cat
// (docs/reduced-model.md, "Lag"): only the latest are answered, and a force loop holds its
// prediction at windows + 1 steps past the state, so that further behind the older windows'
// forces are taken as the state's and the terms refer to the held time, a heuristic.
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
    double                tau = 0;   // s: the step W is over
  };

  /// The point's impulse response by inertia alone over a lag, in units of the compliance W:
  /// to a force held over one window, m = 1, 2, ... windows before the present one, the
  /// displacement c_m W and the velocity e_m W / tau at the present window's end.
  struct InertialLagResponse
  {
    static constexpr int       windows = 1;
    std::array<double, windows> c{}, e{};
  };

  /// The response of the generalized-alpha step (alpha_m, alpha_f, beta, gamma; Newmark's
  /// average acceleration: 0, 0, 1/4, 1/2) on a free unit mass: c_m = x_(m+1) / x_1 and
  /// e_m = tau v_(m+1) / x_1 after a unit force over the first step alone, from rest.
  inline InertialLagResponse
  inertial_lag_response(const double alpha_m, const double alpha_f, const double beta, const double gamma)
  {
    InertialLagResponse r;
    // (1 - am) a_(n+1) + am a_n = (1 - af) F_(n+1) + af F_n, tau = 1; Newmark's updates.
    double x = 0, v = 0, a = 0, force = 0, x1 = 0;
    for (int n = 1; n <= InertialLagResponse::windows + 1; ++n)
      {
        const double next_force = n == 1 ? 1 : 0;
        const double a1 = ((1 - alpha_f) * next_force + alpha_f * force - alpha_m * a) / (1 - alpha_m);
        x += v + (0.5 - beta) * a + beta * a1;
        v += (1 - gamma) * a + gamma * a1;
        a = a1, force = next_force;
        if (n == 1)
          x1 = x;
        else
          r.c[n - 2] = x / x1, r.e[n - 2] = v / x1;
      }
    return r;
  }

  struct CouplingTarget
  {
    std::array<double, 3> d{}, d_dot{};   // the device's displacement (m) and velocity (m/s)
    double                stiffness = 0;  // N/m (> 0)
    double                damping   = 0;  // N s/m
    std::array<double, 3> direction{0, 0, -1};
    bool                  unilateral = false;
  };

  /// The coupling's force on the body at time t (s) against the state c (N). `since`: the
  /// forces of the deformation steps after c's and before the present window, oldest first
  /// (N; a force loop behind by that many steps), answered through `lag`, the latest
  /// InertialLagResponse::windows of them.
  inline std::array<double, 3>
  coupling_force(const LocalCompliance &c, const double t, const CouplingTarget &g,
                 const InertialLagResponse *lag = nullptr, const std::array<double, 3> *since = nullptr,
                 const int n_since = 0)
  {
    using V = Eigen::Vector3d;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> W(c.W.data());
    const Eigen::Map<const V> u(c.u.data()), v(c.v.data()), a(c.a.data()), f_k(c.f.data()),
      d(g.d.data()), d_dot(g.d_dot.data()), n(g.direction.data());
    const double k = g.stiffness, s = t - c.time;
    V            moved = V::Zero(), speed = V::Zero(); // the lag's forces' answer
    if (lag && c.tau > 0)
      for (int m = 1; m <= InertialLagResponse::windows && m <= n_since; ++m)
        {
          const V change = W * (Eigen::Map<const V>(since[n_since - m].data()) - f_k);
          moved += lag->c[m - 1] * change, speed += (lag->e[m - 1] / c.tau) * change;
        }
    const V y = k * (d - u - v * s - 0.5 * s * s * a - moved + W * f_k) +
                g.damping * (d_dot - v - s * a - speed);
    // I + k W, with W symmetric positive semi-definite: symmetric positive definite.
    const V f = (Eigen::Matrix3d::Identity() + k * W).ldlt().solve(y);
    if (g.unilateral && f.dot(n) <= 0)
      return {0, 0, 0};
    return {f(0), f(1), f(2)};
  }
} // namespace irdm
