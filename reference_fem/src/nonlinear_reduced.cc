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

  NonlinearElasticity::RigidFields
  NonlinearElasticity::rigid_fields() const
  {
    const auto &L = impl_->linear;
    require_p1(L.scene, "rigid modes");
    const size_t nv = L.dofs_of_vertex.size();
    RigidFields out;
    auto       &fields = out.fields;
    fields.assign(6, std::vector<double>(3 * nv, 0.0));
    for (size_t v = 0; v < nv; ++v)
      for (unsigned a = 0; a < 3; ++a)
        fields[a][3 * v + a] = 1;
    // The centre of mass, from M times the translations (consistent mass).
    double &mass = out.mass;
    Vec3   &c    = out.center_of_mass;
    c            = {0, 0, 0};
    for (unsigned a = 0; a < 3; ++a)
      {
        const std::vector<double> M1 = mass_product(fields[a]);
        double                    m  = 0;
        for (size_t v = 0; v < nv; ++v)
          {
            m += M1[3 * v + a];
            c[a] += M1[3 * v + a] * L.mesh.vertices[v][a];
          }
        mass = m;
        c[a] /= m;
      }
    if (!(mass > 0))
      throw InputError("rigid modes: the body has no mass");
    for (size_t v = 0; v < nv; ++v)
      {
        const Vec3 &x = L.mesh.vertices[v];
        const Vec3  X{x[0] - c[0], x[1] - c[1], x[2] - c[2]};
        for (unsigned a = 0; a < 3; ++a) // e_a x X
          {
            const unsigned b = (a + 1) % 3, d = (a + 2) % 3;
            fields[3 + a][3 * v + d] = X[b];
            fields[3 + a][3 * v + b] = -X[d];
          }
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
    // A free body's K_0 is singular: K_0^+ of the load less its rigid share (inertia relief),
    // by refinement on the factors of K_0 + eps M (eps 1e-9 of the largest K_ii / M_ii, as
    // the sparse route's), each solution made M-orthogonal to the rigid modes.
    const bool     free_body = L.scene.fixed_surfaces.empty();
    const unsigned n         = L.dof_handler.n_dofs();
    std::vector<Vector<double>> rigid, m_rigid;
    double                      shift = 0;
    if (free_body)
      {
        // The rigid modes, M-orthonormal (Gram-Schmidt in the M inner product, twice).
        for (const auto &field : rigid_fields().fields)
          {
            Vector<double> x = to_dofs(L.dofs_of_vertex, n, field), Mx(n);
            for (int pass = 0; pass < 2; ++pass)
              for (size_t k = 0; k < rigid.size(); ++k)
                x.add(-(m_rigid[k] * x), rigid[k]);
            L.mass.vmult(Mx, x);
            const double norm = std::sqrt(x * Mx);
            if (!(norm > 0))
              throw InputError("modal derivatives: the body's rigid modes are not independent");
            x /= norm;
            Mx /= norm;
            rigid.push_back(x);
            m_rigid.push_back(Mx);
          }
        for (unsigned i = 0; i < n; ++i)
          shift = std::max(shift, L.stiffness.diag_element(i) / L.mass.diag_element(i));
        shift *= 1e-9;
      }
    // x less its M-projection on the rigid modes (off), or f less its rigid share (load).
    const auto off = [&](Vector<double> &x) {
      for (size_t k = 0; k < rigid.size(); ++k)
        x.add(-(m_rigid[k] * x), rigid[k]);
    };
    const auto load = [&](Vector<double> &f) {
      for (size_t k = 0; k < rigid.size(); ++k)
        f.add(-(rigid[k] * f), m_rigid[k]);
    };
    SparseMatrix<double> shifted(L.sparsity);
    shifted.copy_from(L.stiffness);
    if (free_body)
      shifted.add(shift, L.mass);
    DirectSolver K0;
    K0.initialize(L.condensed(shifted));
    Vector<double> Ky(n), dy(n);
    const auto solve = [&](Vector<double> &f) { // K_0^-1 f, or K_0^+ (I - M Phi_r Phi_r^T) f
      if (!free_body)
        {
          K0.solve(f);
          return;
        }
      load(f);
      Vector<double> y = f;
      K0.solve(y);
      off(y);
      double previous = 1e300;
      for (unsigned pass = 1; pass <= 30; ++pass)
        {
          L.stiffness.vmult(Ky, y);
          dy = f;
          dy -= Ky;
          K0.solve(dy);
          off(dy);
          y += dy;
          const double change = dy.linfty_norm() / y.linfty_norm();
          if (change <= 1e-15 || change > 0.5 * previous)
            break;
          previous = change;
        }
      f = y;
    };
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
            solve(rhs);
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
