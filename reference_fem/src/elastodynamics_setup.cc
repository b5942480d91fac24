// ElasticDynamics: mesh -> triangulation, DoFs, constraints, assembly of K, M and loads.
#include <deal.II/base/function.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/numerics/vector_tools.h>

#include <irdm_common/error.h>

#include "elastodynamics_impl.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <set>

namespace irdm::fem
{
  IntegratorCoefficients
  IntegratorCoefficients::from_scene(const Scene &s)
  {
    IntegratorCoefficients c;
    if (s.integrator == Integrator::generalized_alpha)
      {
        // Chung & Hulbert (1993): second order, unconditionally stable, rho_inf at dt -> inf.
        const double r = s.rho_inf;
        c.alpha_m = (2 * r - 1) / (r + 1);
        c.alpha_f = r / (r + 1);
        c.gamma   = 0.5 - c.alpha_m + c.alpha_f;
        c.beta    = 0.25 * (1 - c.alpha_m + c.alpha_f) * (1 - c.alpha_m + c.alpha_f);
      }
    return c;
  }

  void
  DirectSolver::initialize(const SparseMatrix<double> &A)
  {
    matrix.reinit(A.get_sparsity_pattern());
    std::vector<PETScWrappers::MatrixBase::size_type> cols;
    std::vector<PetscScalar> vals;
    for (unsigned row = 0; row < A.m(); ++row)
      {
        cols.clear();
        vals.clear();
        for (auto it = A.begin(row); it != A.end(row); ++it)
          {
            cols.push_back(it->column());
            vals.push_back(it->value());
          }
        matrix.set(row, cols.size(), cols.data(), vals.data(), false);
      }
    matrix.compress(VectorOperation::insert);
    x.reinit(MPI_COMM_SELF, A.m(), A.m());
    b.reinit(MPI_COMM_SELF, A.m(), A.m());
    mumps = std::make_unique<PETScWrappers::SparseDirectMUMPS>(control, MPI_COMM_SELF);
    mumps->set_symmetric_mode(true);
    mumps->solve(matrix, x, b); // the first solve factorizes; later ones reuse the factors
  }

  void
  DirectSolver::solve(Vector<double> &v) const
  {
    PetscScalar *p;
    Vec          bv = b;
    VecGetArray(bv, &p);
    std::copy(v.begin(), v.end(), p);
    VecRestoreArray(bv, &p);
    mumps->solve(matrix, x, b);
    const PetscScalar *q;
    Vec                xv = x;
    VecGetArrayRead(xv, &q);
    std::copy(q, q + v.size(), v.begin());
    VecRestoreArrayRead(xv, &q);
  }

  void
  ConstrainedSolver::initialize(const SparseMatrix<double> &A,
                                const AffineConstraints<double> &constraints,
                                const std::vector<types::global_dof_index> &dofs)
  {
    inverse.initialize(A);
    prescribed_dofs = dofs;
    columns.assign(dofs.size(), Vector<double>(A.m()));
    for (unsigned j = 0; j < dofs.size(); ++j)
      {
        columns[j][dofs[j]] = 1.0;
        constraints.set_zero(columns[j]);
        inverse.solve(columns[j]);
      }
    schur_inverse.reinit(dofs.size(), dofs.size());
    for (unsigned i = 0; i < dofs.size(); ++i)
      for (unsigned j = 0; j < dofs.size(); ++j)
        schur_inverse(i, j) = columns[j][dofs[i]];
    if (!dofs.empty())
      schur_inverse.gauss_jordan();
  }

  Vector<double>
  ConstrainedSolver::solve(const AffineConstraints<double> &constraints,
                           Vector<double> &rhs_in_u_out,
                           const Vector<double> &g,
                           const double scale) const
  {
    constraints.set_zero(rhs_in_u_out);
    inverse.solve(rhs_in_u_out);
    const unsigned n = prescribed_dofs.size();
    Vector<double> lambda(n);
    if (n == 0)
      return lambda;
    Vector<double> residual(n);
    for (unsigned i = 0; i < n; ++i)
      residual[i] = g[i] - rhs_in_u_out[prescribed_dofs[i]];
    schur_inverse.vmult(lambda, residual);
    lambda /= scale;
    for (unsigned j = 0; j < n; ++j)
      rhs_in_u_out.add(scale * lambda[j], columns[j]);
    return lambda;
  }

  ElasticDynamics::Impl::Impl(const Scene &s)
    : scene(s)
    , mapping(FE_SimplexP<3>(1))
    , fe(FE_SimplexP<3>(s.fe_degree), 3)
    , quadrature(s.fe_degree + 1) // exact for the P2 mass matrix (degree 4)
    , face_quadrature(s.fe_degree + 1)
    , coeffs(IntegratorCoefficients::from_scene(s))
  {
    const auto t0 = std::chrono::steady_clock::now();
    setup();
    assemble();
    setup_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  void
  ElasticDynamics::Impl::setup()
  {
    mesh = read_gmsh(scene.mesh_file);

    std::vector<Point<3>> vertices;
    for (const auto &v : mesh.vertices)
      vertices.emplace_back(v[0], v[1], v[2]);
    std::vector<CellData<3>> cells(mesh.tets.size(), CellData<3>(4));
    for (unsigned i = 0; i < mesh.tets.size(); ++i)
      {
        for (unsigned k = 0; k < 4; ++k)
          cells[i].vertices[k] = mesh.tets[i][k];
        cells[i].material_id = 0;
      }
    SubCellData faces;
    for (unsigned i = 0; i < mesh.triangles.size(); ++i)
      {
        CellData<2> f(3);
        for (unsigned k = 0; k < 3; ++k)
          f.vertices[k] = mesh.triangles[i][k];
        f.boundary_id = static_cast<types::boundary_id>(mesh.triangle_tags[i]);
        faces.boundary_quads.push_back(f);
      }
    // deal.II's own vertex order convention for tetrahedra (as its gmsh reader does).
    GridTools::invert_cells_with_negative_measure(vertices, cells);
    triangulation.create_triangulation(vertices, cells, faces);

    for (const auto &cell : triangulation.active_cell_iterators())
      total_volume += cell->measure();

    dof_handler.reinit(triangulation);
    dof_handler.distribute_dofs(fe);

    dofs_of_vertex.assign(triangulation.n_vertices(), {{0, 0, 0}});
    dof_component.assign(dof_handler.n_dofs(), 0);
    {
      std::vector<types::global_dof_index> indices(fe.n_dofs_per_cell());
      for (const auto &cell : dof_handler.active_cell_iterators())
        {
          cell->get_dof_indices(indices);
          for (unsigned i = 0; i < indices.size(); ++i)
            dof_component[indices[i]] = fe.system_to_component_index(i).first;
        }
    }
    std::set<unsigned> on_surface;
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        for (const unsigned v : cell->vertex_indices())
          for (unsigned d = 0; d < 3; ++d)
            dofs_of_vertex[cell->vertex_index(v)][d] = cell->vertex_dof_index(v, d);
        for (const unsigned f : cell->face_indices())
          if (cell->face(f)->at_boundary())
            {
              const auto face = cell->face(f);
              std::array<unsigned, 3> tri = {face->vertex_index(0), face->vertex_index(1),
                                             face->vertex_index(2)};
              const Point<3> a = face->vertex(0), b = face->vertex(1), c = face->vertex(2);
              const Tensor<1, 3> normal = cross_product_3d(b - a, c - a);
              if (normal * (face->center() - cell->center()) < 0)
                std::swap(tri[1], tri[2]);
              surface_triangles.push_back(tri);
              surface_triangle_tag.push_back(static_cast<int>(face->boundary_id()));
              on_surface.insert(tri.begin(), tri.end());
            }
      }
    surface_vertices.assign(on_surface.begin(), on_surface.end());

    // Fixed surfaces: homogeneous Dirichlet constraints.
    constraints.clear();
    std::set<types::global_dof_index> already_fixed;
    for (const auto &name : scene.fixed_surfaces)
      {
        const int tag = mesh.surface_tag(name);
        VectorTools::interpolate_boundary_values(mapping, dof_handler,
                                                 static_cast<types::boundary_id>(tag),
                                                 Functions::ZeroFunction<3>(3), constraints);
        const IndexSet dofs = DoFTools::extract_boundary_dofs(
          dof_handler, ComponentMask(), {static_cast<types::boundary_id>(tag)});
        if (dofs.n_elements() == 0)
          throw InputError("fixed surface '" + name + "' has no faces on the boundary of '" +
                           mesh.file + "'");
        std::vector<types::global_dof_index> own;
        for (const auto i : dofs)
          if (already_fixed.insert(i).second)
            own.push_back(i);
        fixed_dofs.push_back(own);
      }
    constraints.close();

    DynamicSparsityPattern dsp(dof_handler.n_dofs());
    DoFTools::make_sparsity_pattern(dof_handler, dsp);
    sparsity.copy_from(dsp);
    stiffness.reinit(sparsity);
    mass.reinit(sparsity);
    place_scene_on_mesh();
  }

  void
  ElasticDynamics::Impl::place_scene_on_mesh()
  {
    for (const auto &f : scene.vertex_forces)
      {
        const unsigned v = select_vertex(f.vertex, "load '" + f.name + "'");
        // A force on a fixed vertex goes straight into the support: almost surely a mistake.
        if (constraints.is_constrained(dofs_of_vertex[v][0]))
          throw InputError("load '" + f.name + "': its vertex (node tag " +
                           std::to_string(mesh.node_tags[v]) + ") lies on a fixed surface, so "
                           "the force would act on nothing");
        force_vertex.push_back(v);
      }
    for (const auto &p : scene.prescribed)
      {
        const unsigned v = select_vertex(p.vertex, "prescribed displacement '" + p.name + "'");
        for (unsigned d = 0; d < 3; ++d)
          {
            const auto dof = dofs_of_vertex[v][d];
            if (constraints.is_constrained(dof))
              throw InputError("prescribed displacement '" + p.name +
                               "': its vertex lies on a fixed surface");
            for (const auto other : probe_dofs)
              if (other == dof)
                throw InputError("prescribed displacement '" + p.name +
                                 "': two probes on the same vertex");
            probe_dofs.push_back(dof);
          }
        probe_vertex.push_back(v);
      }
    for (const auto &p : scene.probes)
      {
        const int tag = [&] {
          try
            {
              return mesh.surface_tag(p.surface);
            }
          catch (const InputError &e)
            {
              throw InputError("probe '" + p.name + "': " + e.what());
            }
        }();
        std::vector<std::array<unsigned, 3>> tris;
        for (unsigned t = 0; t < surface_triangles.size(); ++t)
          if (surface_triangle_tag[t] == tag)
            {
              bool fixed = false;
              for (const unsigned v : surface_triangles[t])
                fixed = fixed || constraints.is_constrained(dofs_of_vertex[v][0]);
              if (!fixed) // a probe on a fixed vertex would fight the support
                tris.push_back(surface_triangles[t]);
            }
        if (tris.empty())
          throw InputError("probe '" + p.name + "': surface '" + p.surface +
                           "' has no triangle off the fixed surfaces");
        probe_triangles.push_back(std::move(tris));
      }
    for (const auto &o : scene.outputs.vertices)
      observed_vertex.push_back(select_vertex(o.vertex, "output vertex '" + o.name + "'"));
  }

  unsigned
  ElasticDynamics::Impl::select_vertex(const VertexSelector &sel, const std::string &what) const
  {
    if (sel.node_tag > 0)
      {
        try
          {
            return mesh.vertex_of_node_tag(sel.node_tag);
          }
        catch (const InputError &e)
          {
            throw InputError(what + ": " + e.what());
          }
      }
    // The nearest surface vertex: probes and loads act on the surface.
    unsigned best = 0;
    double   best_d2 = std::numeric_limits<double>::max();
    for (const unsigned v : surface_vertices)
      {
        double d2 = 0;
        for (unsigned d = 0; d < 3; ++d)
          d2 += (mesh.vertices[v][d] - (*sel.point)[d]) * (mesh.vertices[v][d] - (*sel.point)[d]);
        if (d2 < best_d2)
          best_d2 = d2, best = v;
      }
    // A point far from the body is a mistake (wrong units, another mesh), not a request for
    // the nearest vertex wherever it is: refuse beyond a tenth of the body's size.
    std::array<double, 3> lo = mesh.vertices[0], hi = mesh.vertices[0];
    for (const auto &x : mesh.vertices)
      for (unsigned d = 0; d < 3; ++d)
        lo[d] = std::min(lo[d], x[d]), hi[d] = std::max(hi[d], x[d]);
    const double size = std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    if (std::sqrt(best_d2) > 0.1 * size)
      throw InputError(what + ": nearest_to_m is " + std::to_string(std::sqrt(best_d2)) +
                       " m from the nearest surface vertex, more than a tenth of the body's "
                       "size (" + std::to_string(size) + " m); the point must lie on or near "
                       "the surface (units are m)");
    return best;
  }

  std::array<types::global_dof_index, 3>
  ElasticDynamics::Impl::vertex_dofs(const unsigned vertex) const
  {
    return dofs_of_vertex[vertex];
  }

  void
  ElasticDynamics::Impl::assemble()
  {
    const double E = scene.youngs_modulus, nu = scene.poisson_ratio;
    const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
    const double mu     = E / (2 * (1 + nu));
    const double rho    = scene.density;
    Tensor<1, 3> g;
    for (unsigned d = 0; d < 3; ++d)
      g[d] = scene.gravity_enabled ? scene.gravity[d] : 0.0;
    gravity_force.reinit(dof_handler.n_dofs());

    const FEValuesExtractors::Vector displacement(0);
    FEValues<3> fe_values(mapping, fe, quadrature,
                          update_values | update_gradients | update_JxW_values);
    const unsigned n = fe.n_dofs_per_cell();
    FullMatrix<double> cell_k(n, n), cell_m(n, n);
    Vector<double>     cell_f(n);
    std::vector<types::global_dof_index> dof_indices(n);
    std::vector<SymmetricTensor<2, 3>>   eps(n);
    std::vector<double>                  div(n);
    std::vector<Tensor<1, 3>>            phi(n);

    // CalculiX's C3D4 mass: the integrand at the centroid only (scene "mass_matrix").
    const QGaussSimplex<3> centroid(1);
    FEValues<3> centroid_values(mapping, fe, centroid, update_values | update_JxW_values);

    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        fe_values.reinit(cell);
        cell_k = 0;
        cell_m = 0;
        cell_f = 0;
        for (const unsigned q : fe_values.quadrature_point_indices())
          {
            for (unsigned i = 0; i < n; ++i)
              {
                eps[i] = fe_values[displacement].symmetric_gradient(i, q);
                div[i] = trace(eps[i]);
                phi[i] = fe_values[displacement].value(i, q);
              }
            const double dx = fe_values.JxW(q);
            for (unsigned i = 0; i < n; ++i)
              {
                for (unsigned j = 0; j < n; ++j)
                  {
                    cell_k(i, j) += (2 * mu * scalar_product(eps[i], eps[j]) +
                                     lambda * div[i] * div[j]) * dx;
                    if (!scene.one_point_mass)
                      cell_m(i, j) += rho * (phi[i] * phi[j]) * dx;
                  }
                cell_f(i) += rho * (phi[i] * g) * dx;
              }
          }
        if (scene.one_point_mass)
          {
            centroid_values.reinit(cell);
            for (unsigned i = 0; i < n; ++i)
              for (unsigned j = 0; j < n; ++j)
                cell_m(i, j) += rho * (centroid_values[displacement].value(i, 0) *
                                       centroid_values[displacement].value(j, 0)) *
                                centroid_values.JxW(0);
          }
        cell->get_dof_indices(dof_indices);
        stiffness.add(dof_indices, cell_k);
        mass.add(dof_indices, cell_m);
        for (unsigned i = 0; i < n; ++i)
          gravity_force[dof_indices[i]] += cell_f(i);
      }

    // Surface loads: one assembled vector per unit total force along each axis.
    FEFaceValues<3> face_values(mapping, fe, face_quadrature,
                                update_values | update_JxW_values);
    for (const auto &load : scene.surface_forces)
      {
        const auto tag = static_cast<types::boundary_id>(mesh.surface_tag(load.surface));
        std::array<Vector<double>, 3> unit;
        for (auto &u : unit)
          u.reinit(dof_handler.n_dofs());
        double area = 0;
        for (const auto &cell : dof_handler.active_cell_iterators())
          for (const unsigned f : cell->face_indices())
            if (cell->face(f)->at_boundary() && cell->face(f)->boundary_id() == tag)
              {
                face_values.reinit(cell, f);
                cell->get_dof_indices(dof_indices);
                for (const unsigned q : face_values.quadrature_point_indices())
                  {
                    area += face_values.JxW(q);
                    for (unsigned i = 0; i < n; ++i)
                      {
                        const unsigned c = fe.system_to_component_index(i).first;
                        unit[c][dof_indices[i]] +=
                          face_values.shape_value(i, q) * face_values.JxW(q);
                      }
                  }
              }
        if (!(area > 0))
          throw InputError("surface load '" + load.name + "': surface '" + load.surface +
                           "' has no boundary faces");
        for (auto &u : unit)
          u /= area; // traction = total force / area
        surface_force_unit.push_back(unit);
        surface_area.push_back(area);
      }
  }

  SparseMatrix<double>
  ElasticDynamics::Impl::condensed(const SparseMatrix<double> &A) const
  {
    // Homogeneous constraints: zero the constrained rows and columns, keep the diagonal.
    SparseMatrix<double> C(sparsity);
    C.copy_from(A);
    for (unsigned row = 0; row < C.m(); ++row)
      {
        const bool row_fixed = constraints.is_constrained(row);
        for (auto it = C.begin(row); it != C.end(row); ++it)
          if (it->column() != row && (row_fixed || constraints.is_constrained(it->column())))
            it->value() = 0;
      }
    return C;
  }

  const ConstrainedSolver &
  ElasticDynamics::Impl::stepper() const
  {
    if (factorized)
      return step_solver;
    const auto   t0 = std::chrono::steady_clock::now();
    const double dt = scene.time_step;
    const EffectiveStiffness e(coeffs, StepCoefficients(coeffs, dt), scene.rayleigh_alpha,
                               scene.rayleigh_beta);
    SparseMatrix<double> k_eff(sparsity);
    k_eff.copy_from(stiffness);
    k_eff *= e.stiffness;
    k_eff.add(e.mass, mass);
    effective.reinit(sparsity);
    effective.copy_from(condensed(k_eff));
    step_solver.initialize(effective, constraints, probe_dofs);
    factorization_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    factorized = true;
    return step_solver;
  }

  void
  ElasticDynamics::Impl::external_force(const double t, Vector<double> &f) const
  {
    f = gravity_force;
    for (unsigned l = 0; l < scene.vertex_forces.size(); ++l)
      {
        const Vec3 F = scene.vertex_forces[l].force.at(t);
        for (unsigned d = 0; d < 3; ++d)
          f[dofs_of_vertex[force_vertex[l]][d]] += F[d];
      }
    for (unsigned l = 0; l < scene.surface_forces.size(); ++l)
      {
        const Vec3 F = scene.surface_forces[l].total_force.at(t);
        for (unsigned d = 0; d < 3; ++d)
          if (F[d] != 0)
            f.add(F[d], surface_force_unit[l][d]);
      }
  }

  Vector<double>
  ElasticDynamics::Impl::prescribed_values(const double t) const
  {
    Vector<double> g(probe_dofs.size());
    for (unsigned p = 0; p < scene.prescribed.size(); ++p)
      {
        const Vec3 v = scene.prescribed[p].displacement.at(t);
        for (unsigned d = 0; d < 3; ++d)
          g[3 * p + d] = v[d];
      }
    return g;
  }

  std::vector<Point<3>>
  ElasticDynamics::Impl::dof_support_points() const
  {
    std::vector<Point<3>> x(dof_handler.n_dofs());
    const Quadrature<3>   support(fe.get_unit_support_points());
    FEValues<3>           values(mapping, fe, support, update_quadrature_points);
    std::vector<types::global_dof_index> indices(fe.n_dofs_per_cell());
    for (const auto &cell : dof_handler.active_cell_iterators())
      {
        values.reinit(cell);
        cell->get_dof_indices(indices);
        for (unsigned i = 0; i < indices.size(); ++i)
          x[indices[i]] = values.quadrature_point(i);
      }
    return x;
  }

  Vector<double>
  ElasticDynamics::Impl::initial_velocity() const
  {
    Vector<double> v(dof_handler.n_dofs());
    const Vec3    &v0 = scene.initial_velocity, &w = scene.initial_angular_velocity;
    if (v0 == Vec3{0, 0, 0} && w == Vec3{0, 0, 0})
      return v;
    const auto                  c = mass_properties(mesh, scene.density).center;
    const std::vector<Point<3>> x = dof_support_points();
    for (types::global_dof_index i = 0; i < x.size(); ++i)
      {
        const double   r[3]    = {x[i][0] - c[0], x[i][1] - c[1], x[i][2] - c[2]};
        const double   spin[3] = {w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2],
                                  w[0] * r[1] - w[1] * r[0]};
        const unsigned d       = dof_component[i];
        v[i]                   = v0[d] + spin[d];
      }
    constraints.set_zero(v);
    return v;
  }
} // namespace irdm::fem
