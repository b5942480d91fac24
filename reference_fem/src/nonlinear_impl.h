#pragma once
// Internal: the deal.II side of NonlinearElasticity, shared by its translation units
// (statics in nonlinear_elasticity.cc, dynamics and plane contact in nonlinear_dynamics.cc).
#include <deal.II/fe/fe_values.h>

#include <reference_fem/nonlinear_elasticity.h>

#include "elastodynamics_impl.h"

namespace irdm::fem
{
  /// What the rigid planes do to the body in one configuration.
  struct PlaneContactState
  {
    // N, per plane, on the body's free DoFs: on a grounded body, what the plane pushes into
    // fixed (Dirichlet) nodes goes straight into the support and is not counted.
    std::vector<Vec3>   force;
    std::vector<double> penetration; // m, per plane, deepest free surface vertex (negative: gap)
    double              energy = 0;  // J, penalty energy of the faces that push free DoFs
  };

  class NonlinearElasticity::Impl
  {
  public:
    explicit Impl(const Scene &scene);

    /// Internal force f_int(u) = int P : grad phi, and (if K) the tangent dP/dF. With
    /// `constrained`, the fixed DoFs are condensed out (rows and columns zero, diagonal kept,
    /// residual zero there). Returns false if some quadrature point has J <= 0 (inverted).
    /// If `strain` is given, fills it with the strain measures of RunResult::largest_strain
    /// and strained_volume_fraction at u.
    struct StrainMeasure
    {
      double largest = 0, strained_volume_fraction = 0;
    };
    /// `frame`: the body frame's rotation R for Scene::body_frame_law (the small-strain law
    /// of R^T F; the identity otherwise, where it changes nothing).
    bool
    assemble(const Vector<double> &u, Vector<double> &f_int, SparseMatrix<double> *K,
             bool constrained, double *energy = nullptr, StrainMeasure *strain = nullptr,
             const Tensor<2, 3> &frame = identity()) const;

    /// The rotation of the body's best rigid fit at displacement u: Kabsch's over the mesh
    /// vertices (irdm_common/rigid_fit.h), each weighed by its lumped volume (each cell's
    /// volume shared equally among its vertices), about the weighted centres.
    Tensor<2, 3>
    body_rotation(const Vector<double> &u) const;

    /// The angular velocity (rad/s, world) of the body at displacement u and velocity v that
    /// carries its angular momentum about the centre, with the same lumped vertex weights:
    /// J^-1 sum_v m_v (x_v - c) x (v_v - v_c), J the weights' inertia tensor at x. To first
    /// order in the deformation it is the rate of body_rotation's frame.
    Tensor<1, 3>
    body_angular_velocity(const Vector<double> &u, const Vector<double> &v) const;

    static Tensor<2, 3>
    identity()
    {
      return Tensor<2, 3>(unit_symmetric_tensor<3>());
    }

    /// Stiffness-proportional damping made objective (issue 14): the force int F S_d : grad phi
    /// with S_d = C0 : dE/dt, the reference elasticity tensor C0 on the rate of the
    /// Green-Lagrange strain, dE/dt = sym(F^T grad v). At F = I it is K0 v, the Rayleigh beta
    /// term of the linear FEM; unlike K0 v it is zero for every rigid velocity of a rotated body
    /// (K0 v damps the spin of a free body once it has turned a finite angle). Sets f_d; if
    /// D is given, the tangent d f_d / d v at this u, and if D_u is given, the symmetric part
    /// of d f_d / d u (the full one is not symmetric, and the direct solver is; Newton keeps
    /// its quadratic rate only to the extent the skew part is small). The small-strain law
    /// keeps K0 v exactly (F = I, no dependence on u).
    /// Scene::body_frame_law: F = R (`frame`) in place of I, so that the body's spin as a
    /// whole is not damped either, and the strain rate is that of the law's own strain,
    /// e = sym(R^T F) - I, with the frame turning at `frame_spin` (rad/s, world):
    /// de/dt = sym(R^T grad v) - sym([w_b]x R^T F), w_b = R^T frame_spin. Without the second
    /// term a deformed body's spin would be damped (sym([w_b]x grad u)), which the linear
    /// theory's beta K q' of the body-frame displacement has not. Its dependence on u is left
    /// out of D_u (it is beta |w| against the stiffness).
    void
    damping_force(const Vector<double> &u, const Vector<double> &v, Vector<double> &f_d,
                  SparseMatrix<double> *D, SparseMatrix<double> *D_u = nullptr,
                  const Tensor<2, 3> &frame = identity(),
                  const Tensor<1, 3> &frame_spin = Tensor<1, 3>()) const;

    /// Penalty contact of the scene's planes at time t on the body displaced by u: sets f_c
    /// (force on the body) and, if K is given, adds the penalty tangent
    /// k int (n . phi_i)(n . phi_j) dA over the points in contact.
    PlaneContactState
    plane_contact(const Vector<double> &u, double t, Vector<double> &f_c,
                  SparseMatrix<double> *K) const;

    ElasticDynamics::Impl linear;
    double                lambda = 0, mu = 0;
    // P1: the deformation gradient is constant per cell, so one point integrates f_int and K
    // exactly; P2 keeps the linear solver's rule.
    const QGaussSimplex<3> stiffness_quadrature;
    // P1: the face's vertices with weight area / 3 (lumped, node-based penalty): a plane that
    // touches one vertex (a sharp ear tip) is felt, and each vertex's penalty is independent.
    // P2: Gauss points (lumping P2 faces gives zero vertex weights).
    const Quadrature<2> contact_quadrature;
    std::vector<double>    penalty;            // Pa/m, per plane (the scene's or the default)
    // Boundary faces (cell, face), and the boundary's mesh vertices that are not fixed in all
    // three directions, for contact.
    std::vector<std::pair<DoFHandler<3>::active_cell_iterator, unsigned>> boundary_faces;
    std::vector<unsigned> free_boundary_vertices;
    std::vector<double>   vertex_volume; // m^3, per mesh vertex: its lumped share (body_rotation)

    /// The reference configuration's geometry per cell and quadrature point, computed once:
    /// a Total Lagrangian formulation integrates over the undeformed body, so JxW and the
    /// shape gradients never change, and recomputing them (FEValues::reinit through the
    /// simplex mapping) was most of each Newton iteration's cell loops.
    struct ReferenceCells
    {
      unsigned n_dofs = 0, n_q = 0;
      std::vector<unsigned>                component; // per cell DoF: its vector component
      std::vector<types::global_dof_index> dofs;      // [cell][i]
      std::vector<double>                  JxW;       // [cell][q]
      std::vector<Tensor<1, 3>>            grad;      // [cell][q][i]: g_i, dof i's scalar gradient
      /// grad u at point q of cell c: sum_i u_i e_{c_i} (x) g_i.
      Tensor<2, 3>
      gradient(const Vector<double> &u, size_t c, unsigned q) const;
    };
    ReferenceCells reference;
  };
} // namespace irdm::fem
