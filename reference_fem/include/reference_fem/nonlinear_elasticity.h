#pragma once
// Reference FEM, geometrically nonlinear mode (issue 5, first part): Total Lagrangian
// compressible neo-Hookean elasticity on the scene's body, same mesh, elements and loads as
// ElasticDynamics. Units SI.
//
// Material (strain energy per reference volume, lambda and mu from E and nu):
//   W(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,
//   P    = mu (F - F^{-T}) + lambda ln J F^{-T}.
// Chosen over St Venant-Kirchhoff because it stays stable in compression (W -> infinity as
// J -> 0), which a wall squashing a 2 kPa cat needs, and it reduces to the linear solver's
// Hooke law at small strain (checked by a test).
#include <reference_fem/elastodynamics.h>

#include <memory>

namespace irdm::fem
{
  struct NewtonReport
  {
    unsigned iterations       = 0; // over all load increments
    unsigned line_search_cuts = 0; // step halvings
    double   residual         = 0; // final ||R|| / ||f_ext||
  };

  class NonlinearElasticity
  {
  public:
    explicit NonlinearElasticity(const Scene &scene);
    ~NonlinearElasticity();
    NonlinearElasticity(const NonlinearElasticity &) = delete;
    NonlinearElasticity &
    operator=(const NonlinearElasticity &) = delete;

    /// Static equilibrium under load_scale times the scene's loads at time t (and gravity),
    /// reached in `increments` equal load steps, each solved by Newton's method with a
    /// backtracking line search on the residual norm. One output sample, as
    /// ElasticDynamics::solve_static (strain energy: the neo-Hookean one). Throws InputError
    /// if Newton fails (the report says where).
    RunResult
    solve_static(double t, double load_scale = 1, unsigned increments = 1,
                 NewtonReport *report = nullptr) const;

    /// Consistency of the tangent: at the displacement amplitude * (a smooth field), the
    /// relative difference || K_T d - (R(u + h d) - R(u - h d)) / (2h) || / || K_T d || for a
    /// pseudo-random direction d (central differences, step h relative to |u|).
    double
    tangent_check(double amplitude, double h) const;

  private:
    class Impl;
    std::unique_ptr<Impl> impl_;
  };
} // namespace irdm::fem
