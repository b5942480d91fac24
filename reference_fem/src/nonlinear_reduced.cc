// What a reduced nonlinear model needs of the nonlinear FEM (issue 50): its P1 cells in the
// reference configuration, modal derivatives, mass products and the default penalty. The basis
// and the file are made in reduced_model.cc.
#include <irdm_common/error.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "nonlinear_impl.h"

namespace irdm::fem
{
  namespace
  {
    // A field at every mesh vertex ([3 v + d]) as a DoF vector of the P1 discretization, and back.
    using VertexDofs = std::vector<std::array<types::global_dof_index, 3>>;

    Vector<double>
    to_dofs(const VertexDofs &dofs_of_vertex, const unsigned n_dofs, const std::vector<double> &field)
    {
      Vector<double> x(n_dofs);
      for (size_t v = 0; v < dofs_of_vertex.size(); ++v)
        for (unsigned d = 0; d < 3; ++d)
          x(dofs_of_vertex[v][d]) = field[3 * v + d];
      return x;
    }

    std::vector<double>
    from_dofs(const VertexDofs &dofs_of_vertex, const Vector<double> &x)
    {
      std::vector<double> field(3 * dofs_of_vertex.size());
      for (size_t v = 0; v < dofs_of_vertex.size(); ++v)
        for (unsigned d = 0; d < 3; ++d)
          field[3 * v + d] = x(dofs_of_vertex[v][d]);
      return field;
    }

    void
    require_p1(const Scene &scene, const std::string &what)
    {
      if (scene.fe_degree != 1)
        throw InputError(what + " needs linear (P1) elements; the scene has fe_degree " +
                         std::to_string(scene.fe_degree));
    }
  } // namespace

  NonlinearElasticity::ReferenceTetrahedra
  NonlinearElasticity::reference_tetrahedra() const
  {
    const auto &L = impl_->linear;
    const auto &R = impl_->reference;
    require_p1(L.scene, "a reduced model");
    std::vector<unsigned> vertex_of_dof(L.dof_handler.n_dofs(), 0);
    for (unsigned v = 0; v < L.dofs_of_vertex.size(); ++v)
      for (unsigned d = 0; d < 3; ++d)
        vertex_of_dof[L.dofs_of_vertex[v][d]] = v;
    ReferenceTetrahedra out;
    const size_t n_cells = R.dofs.size() / R.n_dofs;
    for (size_t c = 0; c < n_cells; ++c)
      {
        std::array<unsigned, 4> vertices{};
        std::array<Vec3, 4>     gradients{};
        unsigned                k = 0;
        double                  volume = 0;
        for (unsigned q = 0; q < R.n_q; ++q)
          volume += R.JxW[c * R.n_q + q];
        for (unsigned i = 0; i < R.n_dofs; ++i)
          if (R.component[i] == 0)
            {
              vertices[k] = vertex_of_dof[R.dofs[c * R.n_dofs + i]];
              const Tensor<1, 3> &g = R.grad[c * R.n_dofs + i]; // one point (P1)
              gradients[k]          = {g[0], g[1], g[2]};
              ++k;
            }
        AssertThrow(k == 4, ExcInternalError());
        out.vertices.push_back(vertices);
        out.gradients.push_back(gradients);
        out.volume.push_back(volume);
      }
    return out;
  }

  std::vector<std::vector<double>>
  NonlinearElasticity::modal_derivatives(const std::vector<std::vector<double>> &phi) const
  {
    const auto &L = impl_->linear;
    require_p1(L.scene, "modal derivatives");
    double size = 0; // the body's bounding-box diagonal
    {
      Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
      for (const auto &x : L.mesh.vertices)
        for (int d = 0; d < 3; ++d)
          lo[d] = std::min(lo[d], x[d]), hi[d] = std::max(hi[d], x[d]);
      for (int d = 0; d < 3; ++d)
        size += (hi[d] - lo[d]) * (hi[d] - lo[d]);
      size = std::sqrt(size);
    }
    DirectSolver K0;
    K0.initialize(L.condensed(L.stiffness));
    const unsigned       n = L.dof_handler.n_dofs();
    SparseMatrix<double> K_plus(L.sparsity), K_minus(L.sparsity);
    Vector<double>       f(n), rhs(n);
    std::vector<Vector<double>> dofs;
    for (const auto &p : phi)
      dofs.push_back(to_dofs(L.dofs_of_vertex, L.dof_handler.n_dofs(), p));
    std::vector<std::vector<double>> out;
    for (size_t j = 0; j < dofs.size(); ++j)
      {
        const double largest = dofs[j].linfty_norm();
        if (!(largest > 0))
          throw InputError("modal derivatives: field " + std::to_string(j) + " is zero");
        const double   eps = 1e-5 * size / largest;
        Vector<double> u   = dofs[j];
        u *= eps;
        if (!impl_->assemble(u, f, &K_plus, false))
          throw InputError("modal derivatives: an element inverted at the difference step");
        u *= -1;
        impl_->assemble(u, f, &K_minus, false);
        K_plus.add(-1.0, K_minus); // 2 eps dK/du [phi_j]
        for (size_t i = 0; i <= j; ++i)
          {
            K_plus.vmult(rhs, dofs[i]);
            rhs *= -1 / (2 * eps);
            L.constraints.set_zero(rhs);
            K0.solve(rhs);
            L.constraints.set_zero(rhs);
            out.push_back(from_dofs(L.dofs_of_vertex, rhs));
          }
      }
    return out;
  }

  std::vector<double>
  NonlinearElasticity::mass_product(const std::vector<double> &x) const
  {
    const auto    &L = impl_->linear;
    Vector<double> Mx(L.dof_handler.n_dofs());
    L.mass.vmult(Mx, to_dofs(L.dofs_of_vertex, L.dof_handler.n_dofs(), x));
    return from_dofs(L.dofs_of_vertex, Mx);
  }

  double
  NonlinearElasticity::default_penalty() const
  {
    return impl_->default_penalty;
  }
} // namespace irdm::fem
