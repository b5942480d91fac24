#pragma once
// Internal: the deal.II side of NonlinearElasticity, shared by its translation units
// (statics in nonlinear_elasticity.cc, dynamics and plane contact in nonlinear_dynamics.cc).
#include <deal.II/fe/fe_values.h>

#include <reference_fem/nonlinear_elasticity.h>

#include "elastodynamics_impl.h"

#include <Eigen/Dense>

#include <array>

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

    /// The body frame's rotation at displacement u (Scene::body_frame_law): the best rigid
    /// fit of the nodes weighed by the consistent mass, R maximizing
    /// sum_ij M_ij (R X~_j) . x_i (Kabsch's with H = sum_ij M_ij X~_j x_i^T, X~ = X - C). Its
    /// stationarity, sum_ij M_ij (R^T x_i) x X~_j = 0, is the mean-axis (Tisserand) condition of
    /// the elastic modes, Phi^T M (e_a x X~) = 0, for every u: the frame in which a free body's
    /// modal IRDM (route 2) measures its deformation (docs/free-body.md). A lumped mass would
    /// give another frame, off it by a rotation linear in u.
    Tensor<2, 3>
    body_rotation(const Vector<double> &u) const;
    void
    setup_body_frame();

    /// The angular velocity (rad/s, world) of the body at displacement u and velocity v that
    /// carries its angular momentum about the centre, with the consistent mass:
    /// J^-1 sum_ij M_ij (x_i - c) x v_j, J the inertia tensor at x. It is the rate of
    /// body_rotation's frame but for the deformation's own angular momentum (second order
    /// in u).
    Tensor<1, 3>
    body_angular_velocity(const Vector<double> &u, const Vector<double> &v) const;

    /// Scene::body_frame_law: takes the net torque (about the centre of mass, at displacement
    /// u) out of the internal force f, f -= M (psi x r) with J psi = sum_n r_n x f_n, J the
    /// consistent inertia at u (the correction's net force is zero and its torque J psi).
    /// The law's P = R sigma(e) with R held is not the derivative of a rotation-invariant
    /// energy: its torque, the axial vector of skew(sigma (grad u)^T), is of second order in u
    /// and turns the body, where the floating-frame theory's elastic forces act on the
    /// elastic coordinates alone. The correction is M times a rigid rotation field, so it
    /// drives no elastic mode (to third order in u). Left out of the tangent.
    void
    remove_net_torque(const Vector<double> &u, Vector<double> &f) const;
    /// Node n's three entries of the DoF vector w.
    Eigen::Vector3d
    node_vector(const Vector<double> &w, size_t n) const;
    /// r: every node's place at displacement u less the centre of mass (consistent mass),
    /// as a DoF vector; returns the consistent inertia tensor about that centre.
    Eigen::Matrix3d
    about_centre(const Vector<double> &u, Vector<double> &r) const;

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
    double                 default_penalty = 0; // Pa/m, 100 E over the mean boundary edge
    // Boundary faces (cell, face), and the boundary's mesh vertices that are not fixed in all
    // three directions, for contact.
    std::vector<std::pair<DoFHandler<3>::active_cell_iterator, unsigned>> boundary_faces;
    std::vector<unsigned> free_boundary_vertices;
    // Scene::body_frame_law's frame. A node is a support point with its three DoFs
    // (node_dofs); node_position its place X; node_moment = M_s (X - C) at the node (M_s the
    // scalar consistent mass, M = M_s (x) I_3; C the centre of mass): Kabsch's H in
    // body_rotation is sum_nodes node_moment x^T. Empty without the law.
    std::vector<std::array<types::global_dof_index, 3>> node_dofs;
    std::vector<Eigen::Vector3d>                         node_position, node_moment;
    std::vector<double>                                  node_mass; // kg, M_s's row sums

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
