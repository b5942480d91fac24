#pragma once
// One linear tetrahedron of the reference FEM's Total Lagrangian neo-Hookean law, in Eigen:
// the element kernel a reduced nonlinear model evaluates at its cubature elements (issue 50).
// The FEM's own assembly (reference_fem/src/nonlinear_elasticity.cc) is the same law in deal.II
// tensors; a reduced model with every element and the full basis reproduces the FEM's run
// (tests/test_reduced.cc), which checks the two against each other.
//
// Law (strain energy per reference volume; lambda, mu the Lame constants, Pa):
//   W(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,
//   P    = mu (F - F^{-T}) + lambda ln J F^{-T},
// written in H = grad u so that small strains lose no digits (as the FEM does). P1: the
// gradients g_i of the four shape functions are constant, and one point integrates exactly.
// Node i's displacement u_i gives H = sum_i u_i g_i^T; the element force on node i is
// V P g_i. Damping: the FEM's objective stiffness-proportional force, V F S_d g_i with
// S_d = lambda tr(E') I + 2 mu E', E' = sym(F^T grad v) (the reference Hooke law on the rate of
// the Green-Lagrange strain; K0 v at F = I, zero for every rigid velocity).
#include <Eigen/Dense>

#include <cmath>

namespace irdm::elastic
{
  using Matrix34 = Eigen::Matrix<double, 3, 4>;
  using Vector12 = Eigen::Matrix<double, 12, 1>;
  using Matrix12 = Eigen::Matrix<double, 12, 12>;

  /// A reference tetrahedron: column i of `grad` is shape function i's gradient (1/m), and
  /// its volume (m^3). Element DoF 3 i + a is node i's component a.
  struct Tetrahedron
  {
    Matrix34 grad;
    double   volume = 0;
  };

  /// grad w = sum_i w_i g_i^T for nodal vectors w (12: node-major).
  inline Eigen::Matrix3d
  nodal_gradient(const Tetrahedron &t, const Vector12 &w)
  {
    Eigen::Matrix3d G = Eigen::Matrix3d::Zero();
    for (int i = 0; i < 4; ++i)
      G.noalias() += w.segment<3>(3 * i) * t.grad.col(i).transpose();
    return G;
  }

  /// The law at one point, from H = grad u: F, A = F^{-T}, ln J and the first Piola stress P
  /// (Pa). J - 1 = tr H + (tr(H)^2 - tr(H^2)) / 2 + det H, formed from H so that small
  /// strains lose no digits. False (nothing else set) if J <= 0.
  struct NeoHookeanStress
  {
    Eigen::Matrix3d F, A, P;
    double          lnJ = 0;
  };
  inline bool
  neo_hookean_stress(const Eigen::Matrix3d &H, const double mu, const double lambda, NeoHookeanStress &s)
  {
    const double tH        = H.trace();
    const double J_minus_1 = tH + 0.5 * (tH * tH - (H * H).trace()) + H.determinant();
    if (!(J_minus_1 > -1))
      return false;
    s.lnJ = std::log1p(J_minus_1);
    s.F   = Eigen::Matrix3d::Identity() + H;
    s.A   = s.F.inverse().transpose();
    s.P   = mu * (H + H.transpose() * s.A) + lambda * s.lnJ * s.A;
    return true;
  }

  /// The element's internal force (N, 12) at nodal displacements u and, if K is given, its
  /// tangent (N/m). Returns false if the element is inverted (J <= 0); energy (J) if given.
  inline bool
  neo_hookean_force(const Tetrahedron &t, const Vector12 &u, const double mu, const double lambda,
                    Vector12 &f, Matrix12 *K = nullptr, double *energy = nullptr)
  {
    const Eigen::Matrix3d H = nodal_gradient(t, u);
    NeoHookeanStress      s;
    if (!neo_hookean_stress(H, mu, lambda, s))
      return false;
    const double           lnJ = s.lnJ;
    const Eigen::Matrix3d &A   = s.A;
    const Matrix34         PG  = s.P * t.grad;
    for (int i = 0; i < 4; ++i)
      f.segment<3>(3 * i) = t.volume * PG.col(i);
    if (energy)
      *energy = t.volume * (0.5 * mu * (2 * H.trace() + H.squaredNorm()) - mu * lnJ + 0.5 * lambda * lnJ * lnJ);
    if (!K)
      return true;
    // K(ia, jb) = V [mu d_ab g_i.g_j + (mu - lambda ln J)(A g_j)_a (A g_i)_b
    //               + lambda (A g_j)_b (A g_i)_a]   (dP[G] = mu G + (mu - lambda ln J) A G^T A
    //               + lambda (A : G) A).
    const Matrix34               AG  = A * t.grad;
    const Eigen::Matrix4d        gg  = t.grad.transpose() * t.grad;
    const double                 m2  = mu - lambda * lnJ;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        {
          Eigen::Matrix3d block = m2 * AG.col(j) * AG.col(i).transpose() +
                                  lambda * AG.col(i) * AG.col(j).transpose();
          block.diagonal().array() += mu * gg(i, j);
          K->block<3, 3>(3 * i, 3 * j) = t.volume * block;
        }
    return true;
  }

  /// The damping's second Piola stress S_d = lambda tr(E') I + 2 mu E', E' = sym(F^T grad v).
  inline Eigen::Matrix3d
  damping_stress(const Eigen::Matrix3d &F, const Eigen::Matrix3d &grad_v, const double mu,
                 const double lambda)
  {
    const Eigen::Matrix3d FtG   = F.transpose() * grad_v;
    const Eigen::Matrix3d E_dot = 0.5 * (FtG + FtG.transpose());
    Eigen::Matrix3d       S     = 2 * mu * E_dot;
    S.diagonal().array() += lambda * E_dot.trace();
    return S;
  }

  /// The objective damping force per unit beta (N s / s = N, 12) at displacement u and
  /// velocity v, and if D is given its tangent with respect to v (at this u; its dependence on
  /// u is left out, as a Newton step may).
  inline void
  objective_damping_force(const Tetrahedron &t, const Vector12 &u, const Vector12 &v,
                          const double mu, const double lambda, Vector12 &f, Matrix12 *D = nullptr)
  {
    const Eigen::Matrix3d F  = Eigen::Matrix3d::Identity() + nodal_gradient(t, u);
    const Matrix34        PG = (F * damping_stress(F, nodal_gradient(t, v), mu, lambda)) * t.grad;
    for (int i = 0; i < 4; ++i)
      f.segment<3>(3 * i) = t.volume * PG.col(i);
    if (!D)
      return;
    // D(ia, jb) = V [lambda (F g_i)_a (F g_j)_b + mu ((F F^T)_ab g_i.g_j + (F g_j)_a (F g_i)_b)]
    // (row a of F dotted with g: (F g)_a).
    const Matrix34        FG  = F * t.grad;
    const Eigen::Matrix3d FFt = F * F.transpose();
    const Eigen::Matrix4d gg  = t.grad.transpose() * t.grad;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        D->block<3, 3>(3 * i, 3 * j) =
          t.volume * (lambda * FG.col(i) * FG.col(j).transpose() + mu * gg(i, j) * FFt +
                      mu * FG.col(j) * FG.col(i).transpose());
  }
  /// neo_hookean_force + beta objective_damping_force, the force alone (no tangent): the
  /// residual's element kernel, F and grad u formed once and one product with the gradients.
  /// False if the element is inverted.
  inline bool
  damped_neo_hookean_force(const Tetrahedron &t, const Vector12 &u, const Vector12 &v,
                           const double mu, const double lambda, const double beta, Vector12 &f)
  {
    NeoHookeanStress s;
    if (!neo_hookean_stress(nodal_gradient(t, u), mu, lambda, s))
      return false;
    const Matrix34 PG = (s.P + beta * (s.F * damping_stress(s.F, nodal_gradient(t, v), mu, lambda))) * t.grad;
    for (int i = 0; i < 4; ++i)
      f.segment<3>(3 * i) = t.volume * PG.col(i);
    return true;
  }
} // namespace irdm::elastic
