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

#include <array>
#include <memory>
#include <vector>

namespace irdm::fem
{
  /// Dynamics (run): the linear solver's integrator (Newmark or generalized-alpha, same
  /// coefficients, same Rayleigh damping C = alpha M + beta K_0 with the reference stiffness
  /// K_0), with the internal force at the alpha level, f_int(u_{n+1-alpha_f}). Loads and the
  /// planes' contact forces enter as the linear solver's loads do,
  /// (1 - alpha_f) f_{n+1} + alpha_f f_n, the contact force f_{n+1} being evaluated on u_{n+1}
  /// with the planes at t_{n+1}; so a plane touching during one step is one force sample, as in
  /// the impulse-response convention. Each step is solved by Newton's method: first with the
  /// linear solver's factorized K_eff (cheap, enough for small motion without contact), then,
  /// if that does not contract, with the full tangent (neo-Hookean plus penalty) refactorized
  /// every iteration and a backtracking line search on the residual norm.
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

    /// Runs the scene (kinematics nonlinear: loads, gravity, planes, initial velocity) from
    /// rest to its duration. Outputs as ElasticDynamics::run plus the planes' forces and
    /// penetrations and the contact and gravity energies; strain energy is the neo-Hookean one.
    /// The callback, if given, gets the fraction done about every 5 %. Throws InputError if
    /// Newton fails at a step (an element inverted, or no convergence: use a smaller step).
    RunResult
    run(const std::function<void(double)> &progress = {}, const SampleSink &sink = {},
        unsigned batch = 4096) const;

    /// Writes the scene's outputs (HDF5 and CSV as configured) for a result of this solver.
    void
    write_outputs(const RunResult &result) const;
    /// Degrees of freedom of the discretization (fixed ones included).
    unsigned
    n_dofs() const;

    /// Consistency of the tangent: at the displacement amplitude * (a smooth field), the
    /// relative difference || K_T d - (R(u + h d) - R(u - h d)) / (2h) || / || K_T d || for a
    /// pseudo-random direction d (central differences, step h relative to |u|).
    double
    tangent_check(double amplitude, double h) const;

    /// The body's P1 cells in the reference configuration, for a reduced model
    /// (reduced_model.h): each cell's four mesh vertices, its shape functions' gradients (1/m)
    /// and its volume (m^3). InputError for elements of higher degree.
    struct ReferenceTetrahedra
    {
      std::vector<std::array<unsigned, 4>> vertices;
      std::vector<std::array<Vec3, 4>>     gradients;
      std::vector<double>                  volume;
    };
    ReferenceTetrahedra
    reference_tetrahedra() const;

    /// Modal derivatives (Idelsohn and Cardona 1985; Barbic and James 2005) of the fields phi
    /// (displacements at every mesh vertex, [3 v + d], zero at fixed DoFs): for every pair
    /// i <= j (in the order (0,0), (0,1), (1,1), (0,2), ...),
    ///   K_0 psi_ij = -(dK/du [phi_j]) phi_i,
    /// the second derivative of the internal force taken by central differences of the
    /// tangent at +-eps phi_j (eps phi_j's largest component 1e-5 of the body's size). A free
    /// body (no fixed surface): K_0^+ of the load less its rigid share (inertia relief), each
    /// derivative M-orthogonal to the rigid modes. P1 only.
    std::vector<std::vector<double>>
    modal_derivatives(const std::vector<std::vector<double>> &phi) const;
    /// The six rigid-body velocity fields at every mesh vertex: unit translations along x, y,
    /// z (m/s per unit), then unit-rate rotations about x, y, z through the centre of mass
    /// (e_a x (X - c), m/s per rad/s); the body's mass (kg) and centre of mass (m, from the
    /// consistent mass). P1 only.
    struct RigidFields
    {
      std::vector<std::vector<double>> fields;
      double                           mass = 0;
      Vec3                             center_of_mass{0, 0, 0};
    };
    RigidFields
    rigid_fields() const;
    /// M x (consistent mass) of a field at every mesh vertex, same layout.
    std::vector<double>
    mass_product(const std::vector<double> &x) const;
    /// The planes' penalty when the scene gives none (Pa/m): 100 E over the mean boundary
    /// edge.
    double
    default_penalty() const;

  private:
    class Impl;
    class TimeLoop; // run()'s state, step and Newton's method (nonlinear_dynamics.cc)
    std::unique_ptr<Impl> impl_;
  };
} // namespace irdm::fem
