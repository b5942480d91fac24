// Total Lagrangian neo-Hookean statics on the linear solver's discretization (its Impl gives
// the mesh, elements, mapping, constraints and loads), in the step-44 shape: assemble the
// residual and the tangent, solve with Newton plus line search.
#include <deal.II/lac/sparse_direct.h>

#include <irdm_common/error.h>
#include <irdm_common/rigid_fit.h>

#include <Eigen/Dense>

#include <cmath>
#include <random>

#include "nonlinear_impl.h"

namespace irdm::fem
{
  namespace
  {
    // [w]x: the skew matrix of w x.
    Tensor<2, 3>
    cross_matrix(const Tensor<1, 3> &w)
    {
      Tensor<2, 3> W;
      W[0][1] = -w[2], W[0][2] = w[1], W[1][0] = w[2];
      W[1][2] = -w[0], W[2][0] = -w[1], W[2][1] = w[0];
      return W;
    }

    // The corotational law at a point (Scene::corotational_law), from H = grad u: F = I + H =
    // R S with R proper (a reflected F keeps det R = 1: its smallest singular value takes the
    // sign), e = S - I, energy density psi = mu e:e + lambda/2 tr(e)^2 (a function of S: objective),
    // P = d psi / dF = R (lambda tr(e) I + 2 mu e). The tangent, with dR = R [w]x and
    // (tr(S) I - S) w = axial(R^T dF - dF^T R) (the derivative of the polar rotation):
    //   dP = 2 mu dF + (lambda tr(e) - 2 mu) dR + lambda tr(R^T dF) R.
    // dP_dF[a][B][c][D] = d P_aB / d F_cD. False where tr(S) I - S is singular (a point
    // collapsed onto a line), which no admissible deformation reaches.
    bool
    corotational_point(const Tensor<2, 3> &H, const double mu, const double lambda,
                       Tensor<2, 3> &P, double &psi, Tensor<4, 3> *dP_dF)
    {
      Eigen::Matrix3d F;
      for (unsigned a = 0; a < 3; ++a)
        for (unsigned b = 0; b < 3; ++b)
          F(a, b) = (a == b) + H[a][b];
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d U = svd.matrixU();
      if ((U * svd.matrixV().transpose()).determinant() < 0)
        U.col(2) *= -1; // the smallest singular value's direction: S takes the sign
      const Eigen::Matrix3d Re = U * svd.matrixV().transpose();
      Tensor<2, 3>          R;
      for (unsigned a = 0; a < 3; ++a)
        for (unsigned b = 0; b < 3; ++b)
          R[a][b] = Re(a, b);
      // e = R^T F - I = R^T H + (R^T - I): no digits lost to I at small strain.
      const Tensor<2, 3> I  = unit_symmetric_tensor<3>();
      const Tensor<2, 3> Rt = transpose(R);
      const Tensor<2, 3> X  = Rt * H + (Rt - I);
      const Tensor<2, 3> e  = 0.5 * (X + transpose(X));
      const double       te = trace(e);
      P   = R * (lambda * te * I + 2 * mu * e);
      psi = mu * scalar_product(e, e) + 0.5 * lambda * te * te;
      if (!dP_dF)
        return true;
      const Tensor<2, 3> S = I + e;
      const Tensor<2, 3> G = (3 + te) * I - S; // tr(S) I - S
      if (!(std::abs(determinant(G)) > 1e-12))
        return false;
      const Tensor<2, 3> G_inv = invert(G);
      for (unsigned c = 0; c < 3; ++c)
        for (unsigned D = 0; D < 3; ++D)
          {
            Tensor<2, 3> dF;
            dF[c][D]              = 1;
            const Tensor<2, 3> A  = Rt * dF - transpose(dF) * R; // skew
            Tensor<1, 3>       axial;
            axial[0] = A[2][1], axial[1] = A[0][2], axial[2] = A[1][0];
            const Tensor<1, 3> w  = G_inv * axial;
            const Tensor<2, 3> dR = R * cross_matrix(w);
            const Tensor<2, 3> dP = 2 * mu * dF + (lambda * te - 2 * mu) * dR + lambda * R[c][D] * R;
            for (unsigned a = 0; a < 3; ++a)
              for (unsigned B = 0; B < 3; ++B)
                (*dP_dF)[a][B][c][D] = dP[a][B];
          }
      return true;
    }

    // K_ij += dx grad phi_i : dP[grad phi_j] = dx sum_BD dP_dF[c_i][B][c_j][D] g_i[B] g_j[D], for
    // shape functions e_{c_i} N_i with scalar gradients g_i.
    void
    add_tangent(const Tensor<4, 3> &dP_dF, const std::vector<Tensor<1, 3>> &g,
                const std::vector<unsigned> &component, const double dx, FullMatrix<double> &cell_K)
    {
      for (unsigned i = 0; i < g.size(); ++i)
        for (unsigned j = 0; j < g.size(); ++j)
          {
            double k_ij = 0;
            for (unsigned B = 0; B < 3; ++B)
              for (unsigned D = 0; D < 3; ++D)
                k_ij += dP_dF[component[i]][B][component[j]][D] * g[i][B] * g[j][D];
            cell_K(i, j) += k_ij * dx;
          }
    }
  } // namespace

  namespace
  {
    // The penalty's face rule. P1: the vertices (the penalty lumped to them by area / 3). P2:
    // the vertices, edge midpoints and centroid (weights 1/40, 1/15, 9/40 on the unit
    // triangle; positive, exact to degree 3): with Gauss points alone a vertex at a sharp
    // feature passes through the plane unseen (an ear tip through a wall pressed into the
    // cat's top), which the P1 rule does not allow. Higher degrees: Gauss points.
    Quadrature<2>
    contact_rule(const unsigned degree)
    {
      if (degree == 1)
        return Quadrature<2>({Point<2>(0, 0), Point<2>(1, 0), Point<2>(0, 1)}, {1. / 6, 1. / 6, 1. / 6});
      if (degree == 2)
        return Quadrature<2>({Point<2>(0, 0), Point<2>(1, 0), Point<2>(0, 1), Point<2>(0.5, 0),
                              Point<2>(0.5, 0.5), Point<2>(0, 0.5), Point<2>(1. / 3, 1. / 3)},
                             {1. / 40, 1. / 40, 1. / 40, 1. / 15, 1. / 15, 1. / 15, 9. / 40});
      return Quadrature<2>(QGaussSimplex<2>(degree + 2));
    }
  } // namespace

  NonlinearElasticity::Impl::Impl(const Scene &scene)
    : linear(scene)
    , stiffness_quadrature(scene.fe_degree == 1 ? 1 : scene.fe_degree + 1)
    , contact_quadrature(contact_rule(scene.fe_degree))
  {
    const double E = scene.youngs_modulus, nu = scene.poisson_ratio;
    lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
    mu     = E / (2 * (1 + nu));
    std::vector<bool> on_boundary(linear.triangulation.n_vertices(), false);
    double            edge_sum = 0;
    unsigned          n_edges  = 0;
    for (const auto &cell : linear.dof_handler.active_cell_iterators())
      for (const unsigned f : cell->face_indices())
        if (cell->face(f)->at_boundary())
          {
            boundary_faces.emplace_back(cell, f);
            const auto face = cell->face(f);
            for (const unsigned v : face->vertex_indices())
              {
                on_boundary[face->vertex_index(v)] = true;
                edge_sum += face->vertex(v).distance(face->vertex((v + 1) % 3));
                ++n_edges;
              }
          }
    for (unsigned v = 0; v < on_boundary.size(); ++v)
      if (on_boundary[v])
        {
          const auto &dv = linear.dofs_of_vertex[v];
          if (!(linear.constraints.is_constrained(dv[0]) &&
                linear.constraints.is_constrained(dv[1]) &&
                linear.constraints.is_constrained(dv[2])))
            free_boundary_vertices.push_back(v);
        }
    const double h = edge_sum / std::max(1u, n_edges);
    if (scene.body_frame_law)
      setup_body_frame();
    default_penalty = 100 * E / h;
    for (const auto &p : scene.planes)
      penalty.push_back(p.penalty > 0 ? p.penalty : default_penalty);

    FEValues<3> fv(linear.mapping, linear.fe, stiffness_quadrature,
                   update_gradients | update_JxW_values);
    auto &r  = reference;
    r.n_dofs = linear.fe.n_dofs_per_cell();
    r.n_q    = stiffness_quadrature.size();
    for (unsigned i = 0; i < r.n_dofs; ++i)
      r.component.push_back(linear.fe.system_to_component_index(i).first);
    const size_t n_cells = linear.triangulation.n_active_cells();
    r.dofs.resize(n_cells * r.n_dofs);
    r.JxW.resize(n_cells * r.n_q);
    r.grad.resize(n_cells * r.n_q * r.n_dofs);
    std::vector<types::global_dof_index> dofs(r.n_dofs);
    size_t                               c = 0;
    for (const auto &cell : linear.dof_handler.active_cell_iterators())
      {
        fv.reinit(cell);
        cell->get_dof_indices(dofs);
        std::copy(dofs.begin(), dofs.end(), r.dofs.begin() + c * r.n_dofs);
        for (unsigned q = 0; q < r.n_q; ++q)
          {
            r.JxW[c * r.n_q + q] = fv.JxW(q);
            for (unsigned i = 0; i < r.n_dofs; ++i)
              r.grad[(c * r.n_q + q) * r.n_dofs + i] = fv.shape_grad_component(i, q, r.component[i]);
          }
        ++c;
      }
  }

  Tensor<2, 3>
  NonlinearElasticity::Impl::ReferenceCells::gradient(const Vector<double> &u, const size_t c,
                                                     const unsigned q) const
  {
    Tensor<2, 3>                   G;
    const types::global_dof_index *d = &dofs[c * n_dofs];
    const Tensor<1, 3>            *g = &grad[(c * n_q + q) * n_dofs];
    for (unsigned i = 0; i < n_dofs; ++i)
      G[component[i]] += u(d[i]) * g[i];
    return G;
  }

  void
  NonlinearElasticity::Impl::setup_body_frame()
  {
    // A node's three DoFs: the local DoFs of a cell with the same index in the base element.
    const auto &dh = linear.dof_handler;
    const auto &fe = linear.fe;
    std::vector<types::global_dof_index> dofs(fe.n_dofs_per_cell());
    std::vector<int> node_of(dh.n_dofs(), -1);
    for (const auto &cell : dh.active_cell_iterators())
      {
        cell->get_dof_indices(dofs);
        for (unsigned i = 0; i < dofs.size(); ++i)
          {
            const auto [component, base] = fe.system_to_component_index(i);
            if (component != 0 || node_of[dofs[i]] >= 0)
              continue;
            std::array<types::global_dof_index, 3> triple{};
            for (unsigned j = 0; j < dofs.size(); ++j)
              if (fe.system_to_component_index(j).second == base)
                triple[fe.system_to_component_index(j).first] = dofs[j];
            node_of[dofs[i]] = static_cast<int>(node_dofs.size());
            node_dofs.push_back(triple);
          }
      }
    const std::vector<Point<3>> x = linear.dof_support_points();
    for (const auto &d : node_dofs)
      node_position.emplace_back(x[d[0]][0], x[d[0]][1], x[d[0]][2]);
    // M_s applied to a scalar field on the nodes: the vector mass matrix on the field placed
    // in the x components (M = M_s (x) I_3), read back there.
    Vector<double> in(dh.n_dofs()), out(dh.n_dofs());
    const auto apply_scalar_mass = [&](const auto &field, std::vector<double> &result) {
      in = 0;
      for (size_t n = 0; n < node_dofs.size(); ++n)
        in(node_dofs[n][0]) = field(n);
      linear.mass.vmult(out, in);
      result.resize(node_dofs.size());
      for (size_t n = 0; n < node_dofs.size(); ++n)
        result[n] = out(node_dofs[n][0]);
    };
    apply_scalar_mass([](size_t) { return 1.0; }, node_mass);
    double          m = 0;
    Eigen::Vector3d C = Eigen::Vector3d::Zero();
    for (size_t n = 0; n < node_dofs.size(); ++n)
      m += node_mass[n], C += node_mass[n] * node_position[n];
    C /= m;
    node_moment.assign(node_dofs.size(), Eigen::Vector3d::Zero());
    std::vector<double> moment;
    for (int a = 0; a < 3; ++a)
      {
        apply_scalar_mass([&](size_t n) { return node_position[n](a) - C(a); }, moment);
        for (size_t n = 0; n < node_dofs.size(); ++n)
          node_moment[n](a) = moment[n];
      }
  }

  Tensor<2, 3>
  NonlinearElasticity::Impl::body_rotation(const Vector<double> &u) const
  {
    // sum_ij M_ij X~_j x_i^T: the centre of the deformed nodes drops out, since
    // sum_n node_moment = M_s-weighted sum of X - C = 0.
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (size_t n = 0; n < node_dofs.size(); ++n)
      {
        const auto           &d = node_dofs[n];
        const Eigen::Vector3d xn = node_position[n] + Eigen::Vector3d(u(d[0]), u(d[1]), u(d[2]));
        H += node_moment[n] * xn.transpose();
      }
    const Eigen::Matrix3d R = kabsch_rotation(H);
    Tensor<2, 3>          out;
    for (unsigned a = 0; a < 3; ++a)
      for (unsigned b = 0; b < 3; ++b)
        out[a][b] = R(a, b);
    return out;
  }

  Eigen::Vector3d
  NonlinearElasticity::Impl::node_vector(const Vector<double> &w, const size_t n) const
  {
    return Eigen::Vector3d(w(node_dofs[n][0]), w(node_dofs[n][1]), w(node_dofs[n][2]));
  }

  Eigen::Matrix3d
  NonlinearElasticity::Impl::about_centre(const Vector<double> &u, Vector<double> &r) const
  {
    const size_t    N = node_dofs.size();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    double          m = 0;
    for (size_t n = 0; n < N; ++n)
      c += node_mass[n] * (node_position[n] + node_vector(u, n)), m += node_mass[n];
    c /= m;
    r.reinit(u.size());
    for (size_t n = 0; n < N; ++n)
      for (int a = 0; a < 3; ++a)
        r(node_dofs[n][a]) = node_position[n](a) + u(node_dofs[n][a]) - c(a);
    // J = tr(S) I - S, S = sum_n r_n (M r)_n^T (M = M_s (x) I_3: S_ab = sum_ij M_s,ij r_ia r_jb).
    Vector<double> Mr(u.size());
    linear.mass.vmult(Mr, r);
    Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
    for (size_t n = 0; n < N; ++n)
      S += node_vector(r, n) * node_vector(Mr, n).transpose();
    return S.trace() * Eigen::Matrix3d::Identity() - 0.5 * (S + S.transpose());
  }

  Tensor<1, 3>
  NonlinearElasticity::Impl::body_angular_velocity(const Vector<double> &u, const Vector<double> &v) const
  {
    // L = sum_n r_n x (M v)_n; a velocity common to every node drops out (sum_n M_s r_n = 0
    // about the centre of mass).
    Vector<double>        r, Mv(u.size());
    const Eigen::Matrix3d J = about_centre(u, r);
    linear.mass.vmult(Mv, v);
    Eigen::Vector3d L = Eigen::Vector3d::Zero();
    for (size_t n = 0; n < node_dofs.size(); ++n)
      L += node_vector(r, n).cross(node_vector(Mv, n));
    const Eigen::Vector3d w = J.ldlt().solve(L);
    Tensor<1, 3>          out;
    for (unsigned a = 0; a < 3; ++a)
      out[a] = w(a);
    return out;
  }

  void
  NonlinearElasticity::Impl::remove_net_torque(const Vector<double> &u, Vector<double> &f) const
  {
    Vector<double>        r, Mr(u.size());
    const Eigen::Matrix3d J      = about_centre(u, r);
    Eigen::Vector3d       torque = Eigen::Vector3d::Zero();
    for (size_t n = 0; n < node_dofs.size(); ++n)
      torque += node_vector(r, n).cross(node_vector(f, n));
    const Eigen::Vector3d psi = J.ldlt().solve(torque);
    for (size_t n = 0; n < node_dofs.size(); ++n)
      {
        const Eigen::Vector3d turn = psi.cross(node_vector(r, n));
        for (int a = 0; a < 3; ++a)
          r(node_dofs[n][a]) = turn(a);
      }
    linear.mass.vmult(Mr, r);
    f -= Mr;
  }

  bool
  NonlinearElasticity::Impl::assemble(const Vector<double> &u, Vector<double> &f_int,
                                       SparseMatrix<double> *K, const bool constrained,
                                       double *energy, StrainMeasure *strain,
                                       const Tensor<2, 3> &frame) const
  {
    const auto &L = linear;
    const auto    &R      = reference;
    const unsigned n_dofs = R.n_dofs, n_q = R.n_q;
    FullMatrix<double>                   cell_K(n_dofs, n_dofs);
    Vector<double>                       cell_f(n_dofs);
    std::vector<types::global_dof_index> dofs(n_dofs);
    // Shape function i of the vector element is e_{c_i} N_i: its gradient is e_{c_i} (x) g_i,
    // so the tangent needs only the scalar gradients g_i and A g_i with A = F^{-T}.
    const std::vector<unsigned> &component = R.component;
    std::vector<Tensor<1, 3>>    g(n_dofs), Ag(n_dofs);
    f_int.reinit(L.dof_handler.n_dofs());
    if (K)
      *K = 0;
    if (energy)
      *energy = 0;
    if (strain)
      *strain = StrainMeasure();
    double       strained_volume = 0, volume = 0;
    bool         ok      = true;
    // The small-strain law's body frame (Scene::body_frame_law): R^T and R^T - I, once.
    const Tensor<2, 3> Rt = transpose(frame), Rt_minus_I = Rt - identity();
    const size_t n_cells = R.dofs.size() / n_dofs;
    for (size_t c = 0; c < n_cells; ++c)
      {
        std::copy_n(&R.dofs[c * n_dofs], n_dofs, dofs.begin());
        cell_K = 0;
        cell_f = 0;
        for (unsigned q = 0; q < n_q; ++q)
          {
            // Written in H = grad u so that small strains lose no digits to cancellation:
            // J - 1 = tr H + (tr(H)^2 - tr(H^2)) / 2 + det H, F - F^{-T} = H + H^T F^{-T}.
            // The small-strain law takes the displacement gradient in the body frame,
            // R^T F - I = R^T H + (R^T - I) (H itself when R = I, Scene::body_frame_law off).
            const Tensor<2, 3>  H  = L.scene.small_strain_law
                                       ? Rt * R.gradient(u, c, q) + Rt_minus_I
                                       : R.gradient(u, c, q);
            const double        tH = trace(H);
            const double        dx = R.JxW[c * n_q + q];
            if (strain)
              {
                // The principal stretches' largest departure from 1: lambda_i^2 are the
                // eigenvalues of C = F^T F = I + 2E (the small-strain law: eps's eigenvalues).
                const SymmetricTensor<2, 3> e =
                  L.scene.small_strain_law ? symmetrize(H) : symmetrize(H) + 0.5 * symmetrize(transpose(H) * H);
                double largest = 0;
                for (const double e_i : eigenvalues(e))
                  largest = std::max(largest, L.scene.small_strain_law ? std::abs(e_i)
                                                                       : std::abs(std::sqrt(std::max(0.0, 1 + 2 * e_i)) - 1));
                strain->largest = std::max(strain->largest, largest);
                volume += dx;
                if (largest > 0.1)
                  strained_volume += dx;
              }
            // The small-strain law is the same formulas with A = F^{-T} -> I and ln J -> tr H.
            double       lnJ   = tH;
            Tensor<2, 3> FinvT = unit_symmetric_tensor<3>();
            Tensor<2, 3> P;
            Tensor<4, 3> dP_dF; // the corotational law's tangent
            if (L.scene.corotational_law)
              {
                double psi = 0;
                if (!corotational_point(H, mu, lambda, P, psi, K ? &dP_dF : nullptr))
                  {
                    ok = false;
                    continue;
                  }
                if (energy)
                  *energy += dx * psi;
              }
            else if (L.scene.small_strain_law)
              {
                // P = R S(eps): the first Piola stress of the body-frame law, whose tangent
                // is the formulas below with A = R (R's rows are orthonormal).
                FinvT = frame;
                P     = frame * (mu * (H + transpose(H)) + lambda * tH * identity());
                if (energy)
                  *energy += dx * (0.25 * mu * scalar_product(H + transpose(H), H + transpose(H)) +
                                   0.5 * lambda * tH * tH);
              }
            else
              {
                const Tensor<2, 3> F = unit_symmetric_tensor<3>() + H;
                const double J_minus_1 =
                  tH + 0.5 * (tH * tH - scalar_product(H, transpose(H))) + determinant(H);
                if (!(J_minus_1 > -1))
                  {
                    ok = false;
                    continue;
                  }
                lnJ   = std::log1p(J_minus_1);
                FinvT = transpose(invert(F));
                P     = mu * (H + transpose(H) * FinvT) + lambda * lnJ * FinvT;
                if (energy)
                  *energy += dx * (0.5 * mu * (2 * tH + scalar_product(H, H)) - mu * lnJ +
                                   0.5 * lambda * lnJ * lnJ); // tr(F^T F) - 3 = 2 tr H + H:H
              }
            for (unsigned i = 0; i < n_dofs; ++i)
              {
                g[i]  = R.grad[(c * n_q + q) * n_dofs + i];
                Ag[i] = FinvT * g[i];
                cell_f(i) += (P * g[i])[component[i]] * dx;
              }
            if (!K)
              continue;
            if (L.scene.corotational_law)
              {
                add_tangent(dP_dF, g, component, dx, cell_K);
                continue;
              }
            // K_ij = grad phi_i : dP[grad phi_j], with
            // dP[G] = mu G + (mu - lambda ln J) A G^T A + lambda (A : G) A, A = F^{-T}:
            // K_ij = mu d_{c_i c_j} g_i.g_j + (mu - lambda ln J)(A g_j)_{c_i} (A g_i)_{c_j}
            //        + lambda (A g_j)_{c_j} (A g_i)_{c_i}.
            const double m2 = L.scene.small_strain_law ? mu : mu - lambda * lnJ;
            for (unsigned i = 0; i < n_dofs; ++i)
              for (unsigned j = 0; j < n_dofs; ++j)
                {
                  const unsigned ci = component[i], cj = component[j];
                  double k_ij = m2 * Ag[j][ci] * Ag[i][cj] + lambda * Ag[j][cj] * Ag[i][ci];
                  if (ci == cj)
                    k_ij += mu * (g[i] * g[j]);
                  cell_K(i, j) += k_ij * dx;
                }
          }
        for (unsigned i = 0; i < n_dofs; ++i)
          f_int(dofs[i]) += cell_f(i);
        if (K)
          K->add(dofs, cell_K);
      }
    if (constrained)
      {
        for (unsigned row = 0; row < f_int.size(); ++row)
          if (L.constraints.is_constrained(row))
            f_int(row) = 0;
        if (K)
          *K = L.condensed(*K);
      }
    if (strain && volume > 0)
      strain->strained_volume_fraction = strained_volume / volume;
    return ok;
  }

  void
  NonlinearElasticity::Impl::damping_force(const Vector<double> &u, const Vector<double> &v,
                                           Vector<double> &f_d, SparseMatrix<double> *D,
                                           SparseMatrix<double> *D_u,
                                           const Tensor<2, 3> &frame,
                                           const Tensor<1, 3> &frame_spin) const
  {
    if (linear.scene.small_strain_law && D_u)
      {
        *D_u = 0; // F = I: f_d = K0 v does not depend on u
        D_u  = nullptr;
      }
    const auto    &L      = linear;
    const auto    &R      = reference;
    const unsigned n_dofs = R.n_dofs, n_q = R.n_q;
    FullMatrix<double>                   cell_D(n_dofs, n_dofs), cell_Du(n_dofs, n_dofs);
    Vector<double>                       cell_f(n_dofs);
    std::vector<types::global_dof_index> dofs(n_dofs);
    std::vector<Tensor<2, 3>>            grad_u(n_q), grad_v(n_q);
    const std::vector<unsigned>         &component = R.component;
    std::vector<Tensor<1, 3>>            g(n_dofs), f(n_dofs); // f_i: row c_i of F
    std::vector<Tensor<1, 3>>            h(n_dofs), Sg(n_dofs); // row c_i of grad v; S g_i
    f_d.reinit(L.dof_handler.n_dofs());
    if (D)
      *D = 0;
    if (D_u)
      *D_u = 0;
    // [w_b]x, w_b = R^T frame_spin: the frame's spin in its own axes.
    const Tensor<1, 3> w_b = transpose(frame) * frame_spin;
    Tensor<2, 3>       spin_b;
    spin_b[0][1] = -w_b[2], spin_b[0][2] = w_b[1], spin_b[1][0] = w_b[2];
    spin_b[1][2] = -w_b[0], spin_b[2][0] = -w_b[1], spin_b[2][1] = w_b[0];
    const size_t n_cells = R.dofs.size() / n_dofs;
    for (size_t c = 0; c < n_cells; ++c)
      {
        std::copy_n(&R.dofs[c * n_dofs], n_dofs, dofs.begin());
        for (unsigned q = 0; q < n_q; ++q)
          {
            grad_u[q] = R.gradient(u, c, q);
            grad_v[q] = R.gradient(v, c, q);
          }
        cell_D  = 0;
        cell_Du = 0;
        cell_f = 0;
        for (unsigned q = 0; q < n_q; ++q)
          {
            const Tensor<2, 3> F = L.scene.small_strain_law ? frame : identity() + grad_u[q];
            Tensor<2, 3> FtG = transpose(F) * grad_v[q];
            if (L.scene.small_strain_law) // the frame's turn is not a strain rate
              FtG -= spin_b * (transpose(F) * (identity() + grad_u[q]));
            const Tensor<2, 3> E_dot = 0.5 * (FtG + transpose(FtG));
            const Tensor<2, 3> S = lambda * trace(E_dot) * Tensor<2, 3>(unit_symmetric_tensor<3>()) +
                                   2 * mu * E_dot;
            const Tensor<2, 3> P  = F * S;
            const double       dx = R.JxW[c * n_q + q];
            for (unsigned i = 0; i < n_dofs; ++i)
              {
                g[i] = R.grad[(c * n_q + q) * n_dofs + i];
                for (int d = 0; d < 3; ++d)
                  f[i][d] = F[component[i]][d];
                cell_f(i) += (P * g[i])[component[i]] * dx;
              }
            if (D_u)
              {
                // Shape j's displacement gradient G = e_{c_j} (x) g_j changes P = F S by
                // G S + F C0 : sym(G^T grad v), G^T grad v = g_j (x) h_j:
                // (d f_d / d u)_ij = d_{c_i c_j} g_i . S g_j + lambda (g_j . h_j)(f_i . g_i)
                //                    + mu ((f_i . g_j)(h_j . g_i) + (f_i . h_j)(g_j . g_i)).
                for (unsigned i = 0; i < n_dofs; ++i)
                  {
                    for (int d = 0; d < 3; ++d)
                      h[i][d] = grad_v[q][component[i]][d];
                    Sg[i] = S * g[i];
                  }
                const auto du_ij = [&](const unsigned i, const unsigned j) {
                  return (component[i] == component[j] ? g[i] * Sg[j] : 0.0) +
                         lambda * (g[j] * h[j]) * (f[i] * g[i]) +
                         mu * ((f[i] * g[j]) * (h[j] * g[i]) + (f[i] * h[j]) * (g[j] * g[i]));
                };
                for (unsigned i = 0; i < n_dofs; ++i)
                  for (unsigned j = 0; j < n_dofs; ++j)
                    cell_Du(i, j) += 0.5 * dx * (du_ij(i, j) + du_ij(j, i));
              }
            if (!D)
              continue;
            // Shape j's velocity gradient e_{c_j} (x) g_j gives F^T G = f_j (x) g_j, so
            // D_ij = lambda (f_j . g_j)(f_i . g_i) + mu ((f_i . f_j)(g_i . g_j) + (f_i . g_j)(f_j . g_i)),
            // K0 at F = I.
            for (unsigned i = 0; i < n_dofs; ++i)
              for (unsigned j = 0; j < n_dofs; ++j)
                cell_D(i, j) += dx * (lambda * (f[j] * g[j]) * (f[i] * g[i]) +
                                      mu * ((f[i] * f[j]) * (g[i] * g[j]) + (f[i] * g[j]) * (f[j] * g[i])));
          }
        for (unsigned i = 0; i < n_dofs; ++i)
          f_d(dofs[i]) += cell_f(i);
        if (D)
          D->add(dofs, cell_D);
        if (D_u)
          D_u->add(dofs, cell_Du);
      }
  }

  NonlinearElasticity::NonlinearElasticity(const Scene &scene)
    : impl_(std::make_unique<Impl>(scene))
  {}
  NonlinearElasticity::~NonlinearElasticity() = default;

  RunResult
  NonlinearElasticity::solve_static(const double t, const double load_scale,
                                    const unsigned increments, NewtonReport *report) const
  {
    const auto &L = impl_->linear;
    if (L.constraints.n_constraints() == 0)
      throw InputError("static equilibrium needs at least one fixed surface");
    if (L.scene.body_frame_law)
      throw InputError("material.law 'linear_body_frame' is for a free body's dynamics (its "
                       "frame follows the body's motion); statics takes 'linear'");
    if (!L.scene.probes.empty() || !L.scene.prescribed.empty())
      throw InputError("nonlinear statics takes loads only (no probes, no prescribed vertices)");
    if (increments < 1)
      throw InputError("nonlinear statics needs at least one load increment");
    const unsigned n = L.dof_handler.n_dofs();
    Vector<double> f_total(n), f(n), u(n), du(n), r(n), trial(n), f_int(n);
    L.external_force(t, f_total);
    f_total *= load_scale;
    for (unsigned row = 0; row < n; ++row)
      if (L.constraints.is_constrained(row))
        f_total(row) = 0;
    const double f_norm = f_total.l2_norm();
    NewtonReport rep;
    SparseMatrix<double> K(L.sparsity);
    const double tol = 1e-10; // relative residual; 1e-6 is the hard limit below
    for (unsigned inc = 1; inc <= increments; ++inc)
      {
        f.equ(double(inc) / increments, f_total);
        impl_->assemble(u, f_int, nullptr, true);
        r = f_int;
        r -= f;
        unsigned it = 0;
        for (; r.l2_norm() > tol * f_norm && it < 50; ++it)
          {
            double W0 = 0;
            impl_->assemble(u, f_int, &K, true, &W0);
            SparseDirectUMFPACK solver;
            solver.initialize(K);
            du = r;
            du *= -1;
            solver.solve(du);
            // Converged to round-off: the residual of a slender body has a floor well above
            // machine precision relative to its small loads (cancellation in P).
            if (it > 0 && du.linfty_norm() <= 1e-10 * u.linfty_norm())
              break;
            // Backtracking on the potential energy Pi(u) = W(u) - f.u (Armijo): the merit
            // function of hyperelastic statics. (The residual norm is not one here: for a
            // slender body a good Newton step can raise it, as its quadratic part is large
            // next to the small loads that bend it.)
            const double Pi0   = W0 - (f * u);
            const double slope = r * du; // dPi/dalpha at 0, negative for a descent step
            double       alpha = 1;
            bool         accepted = false;
            for (unsigned cut = 0; cut <= 30; ++cut, alpha /= 2)
              {
                trial = u;
                trial.add(alpha, du);
                double     W  = 0;
                const bool ok = impl_->assemble(trial, f_int, nullptr, true, &W);
                // Far from the solution the energy decides; near it the energy's round-off
                // (its first-order terms cancel) hides the decrease, and the residual decides.
                bool better = ok && W - (f * trial) <= Pi0 + 1e-4 * alpha * slope;
                if (ok && !better)
                  {
                    Vector<double> rt = f_int;
                    rt -= f;
                    better = rt.l2_norm() < 0.5 * r.l2_norm();
                  }
                if (better)
                  {
                    accepted = true;
                    break;
                  }
                ++rep.line_search_cuts;
              }
            if (!accepted)
              {
                // No decrease measurable in the energy: round-off, if the step is negligible.
                if (du.linfty_norm() <= 1e-10 * std::max(u.linfty_norm(), 1e-300))
                  break;
                throw InputError("nonlinear statics: the line search found no decrease at load "
                                 "increment " + std::to_string(inc) + " (residual " +
                                 std::to_string(r.l2_norm() / f_norm) + "); use more increments");
              }
            f_int -= f;
            u = trial;
            r = f_int;
          }
        rep.iterations += it;
        if (r.l2_norm() > 1e-6 * f_norm)
          throw InputError("nonlinear statics: Newton did not converge in 50 iterations at load "
                           "increment " + std::to_string(inc) + " (residual " +
                           std::to_string(r.l2_norm() / f_norm) + ")");
      }
    rep.residual = f_norm > 0 ? r.l2_norm() / f_norm : 0;
    if (report)
      *report = rep;
    RunResult out;
    L.init_result(out);
    const Vector<double> zero(n), no_lambda;
    L.record(u, zero, zero, f, no_lambda, t, out);
    double              W = 0;
    Impl::StrainMeasure strain;
    impl_->assemble(u, f_int, nullptr, true, &W, &strain);
    out.strain_energy.back() = W;
    out.largest_strain.push_back(strain.largest);
    out.strained_volume_fraction.push_back(strain.strained_volume_fraction);
    return out;
  }

  double
  NonlinearElasticity::tangent_check(const double amplitude, const double h) const
  {
    const auto    &L = impl_->linear;
    const unsigned n = L.dof_handler.n_dofs();
    Vector<double> u(n), d(n), f_plus(n), f_minus(n), Kd(n), f_int(n);
    // A smooth displacement (bending and twisting in the coordinates), and a random direction.
    std::mt19937                           rng(7);
    std::uniform_real_distribution<double> uniform(-1, 1);
    for (const auto &cell : L.dof_handler.active_cell_iterators())
      for (const unsigned v : cell->vertex_indices())
        {
          const Point<3> x = cell->vertex(v);
          for (unsigned c = 0; c < 3; ++c)
            u(cell->vertex_dof_index(v, c)) =
              amplitude * (std::sin(3 * x[0] + c) * x[(c + 1) % 3] + 0.5 * x[c] * x[(c + 2) % 3] * 10);
        }
    for (unsigned i = 0; i < n; ++i)
      d(i) = uniform(rng) * amplitude;
    SparseMatrix<double> K(L.sparsity);
    // The body-frame law's frame is held within a step: check its tangent in a turned frame.
    const Tensor<2, 3> R = L.scene.body_frame_law ? impl_->body_rotation(u) : Impl::identity();
    impl_->assemble(u, f_int, &K, false, nullptr, nullptr, R);
    K.vmult(Kd, d);
    Vector<double> up = u, um = u;
    up.add(h, d);
    um.add(-h, d);
    impl_->assemble(up, f_plus, nullptr, false, nullptr, nullptr, R);
    impl_->assemble(um, f_minus, nullptr, false, nullptr, nullptr, R);
    f_plus -= f_minus;
    f_plus /= 2 * h;
    f_plus -= Kd;
    return f_plus.l2_norm() / Kd.l2_norm();
  }
} // namespace irdm::fem
