#pragma once
// Internal, plain C++: the coefficients of the FEM's time integrator, shared by the time loop
// (elastodynamics_run.cc), the factorization (elastodynamics_setup.cc) and the modal precompute
// (impulse_response.cc), so that the modal recursion is the FEM's algebra term by term.
#include <reference_fem/scene.h>

namespace irdm::fem
{
  /// Time-integration coefficients; Newmark average acceleration is alpha_m = alpha_f = 0.
  struct IntegratorCoefficients
  {
    double alpha_m = 0, alpha_f = 0, gamma = 0.5, beta = 0.25;
    static IntegratorCoefficients
    from_scene(const Scene &s);
  };

  /// The factors of one step of length dt. The step solves K_eff u_{n+1} = rhs with
  /// K_eff = c_m M + c_c C + (1 - alpha_f) K, and
  /// rhs = (1 - alpha_f) f_{n+1} + alpha_f f_n + M m_part + C c_part - alpha_f K u_n,
  /// m_part = c_m u + m_v v + m_a a,  c_part = c_c u + c_v v + c_a a  (state at step n).
  struct StepCoefficients
  {
    double c_m, c_c, m_v, m_a, c_v, c_a;
    StepCoefficients(const IntegratorCoefficients &c, const double dt)
      : c_m((1 - c.alpha_m) / (c.beta * dt * dt))
      , c_c((1 - c.alpha_f) * c.gamma / (c.beta * dt))
      , m_v((1 - c.alpha_m) / (c.beta * dt))
      , m_a((1 - c.alpha_m) / (2 * c.beta) - 1)
      , c_v((1 - c.alpha_f) * c.gamma / c.beta - 1)
      , c_a((1 - c.alpha_f) * dt * (c.gamma / (2 * c.beta) - 1))
    {}
  };

  // A step's effective stiffness K_eff = c_m M + c_c C + (1 - alpha_f) K with Rayleigh
  // damping C = alpha M + beta K, gathered as K_eff = stiffness K + mass M: the FEM factors
  // it, a mode's step divides by it, and the sparse route's one-step residual modes solve
  // with K + shift() M (the same matrix over `stiffness`).
  struct EffectiveStiffness
  {
    double stiffness, mass;
    EffectiveStiffness(const IntegratorCoefficients &c, const StepCoefficients &k,
                       const double rayleigh_alpha, const double rayleigh_beta)
      : stiffness(1 - c.alpha_f + rayleigh_beta * k.c_c)
      , mass(k.c_m + rayleigh_alpha * k.c_c)
    {}
    double
    shift() const
    {
      return mass / stiffness;
    }
  };
} // namespace irdm::fem
