// The reduced nonlinear model's precompute (reduced_model.h): the basis and the every-element
// file. Plain C++ over the FEM's public API (no deal.II here).
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/reduced_model.h>

#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <Eigen/Dense>

#include <chrono>
#include <cmath>
#include <sstream>

#include "integrator.h"
#include "model_regions.h"
#include "provenance.h"

namespace irdm::fem
{
  namespace
  {
    using Clock = std::chrono::steady_clock;
    double
    since(const Clock::time_point t0)
    {
      return std::chrono::duration<double>(Clock::now() - t0).count();
    }

    // Columns are fields at every mesh vertex ([3 v + d]).
    using Fields = Eigen::MatrixXd;

    Eigen::VectorXd
    mass_product(const NonlinearElasticity &nl, const Eigen::VectorXd &x)
    {
      const std::vector<double> Mx = nl.mass_product(std::vector<double>(x.data(), x.data() + x.size()));
      return Eigen::Map<const Eigen::VectorXd>(Mx.data(), static_cast<Eigen::Index>(Mx.size()));
    }

    // M X, column by column.
    Fields
    mass_times(const NonlinearElasticity &nl, const Fields &X)
    {
      Fields MX(X.rows(), X.cols());
      for (Eigen::Index k = 0; k < X.cols(); ++k)
        MX.col(k) = mass_product(nl, X.col(k));
      return MX;
    }

    // The whole basis made M-orthonormal again (U (U^T M U)^{-1/2}): the PCA directions are
    // M-orthonormal only to round-off, and the runtime takes the reduced mass to be I.
    void
    mass_orthonormalize(const NonlinearElasticity &nl, Fields &U)
    {
      const Eigen::MatrixXd G = U.transpose() * mass_times(nl, U);
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (G + G.transpose()));
      if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0))
        throw InputError("reduced model: the basis is not of full rank");
      U = U * eig.operatorInverseSqrt();
    }
    // The six uniform strain fields e_a (X - c)_b + e_b (X - c)_a (a <= b), read off the rigid
    // rotation fields (about x: (0, -z, y); about y: (z, 0, -x); about z: (-y, x, 0)).
    Fields
    uniform_strain_fields(const std::vector<std::vector<double>> &rigid, const unsigned n_vertices)
    {
      const auto X = [&](const size_t v, const int c) {
        return c == 0 ? rigid[5][3 * v + 1] : c == 1 ? rigid[3][3 * v + 2] : rigid[4][3 * v];
      };
      constexpr int pairs[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
      Fields        S           = Fields::Zero(3 * n_vertices, 6);
      for (int k = 0; k < 6; ++k)
        for (size_t v = 0; v < n_vertices; ++v)
          {
            const int a = pairs[k][0], b = pairs[k][1];
            S(3 * v + a, k) += X(v, b);
            if (a != b)
              S(3 * v + b, k) += X(v, a);
          }
      return S;
    }

    // A free body's six uniform strain fields after its rigid and kept modes (M-orthonormal, so
    // the Gram-Schmidt against them is a projection), themselves made M-orthonormal. With the
    // rigid ones they hold every finite rotation of the body, (Q - I)(X - c), so the floating
    // frame's steps (docs/reduced-model.md) carry a turn's arc, and a spin's stretch.
    unsigned
    append_uniform_strain_fields(const NonlinearElasticity &nl, const std::vector<std::vector<double>> &rigid,
                                 const unsigned n_vertices, Fields &shapes)
    {
      const Eigen::Index kept = shapes.cols();
      shapes.conservativeResize(Eigen::NoChange, kept + 6);
      shapes.rightCols(6) = uniform_strain_fields(rigid, n_vertices);
      for (int pass = 0; pass < 2; ++pass) // Gram-Schmidt against a block loses digits once
        shapes.rightCols(6) -= shapes.leftCols(kept) * (shapes.leftCols(kept).transpose() * mass_times(nl, shapes.rightCols(6)));
      Fields S = shapes.rightCols(6);
      mass_orthonormalize(nl, S);
      shapes.rightCols(6) = S;
      return 6;
    }

    // U^T M w for the six rigid velocity fields w (NonlinearElasticity::rigid_fields), the
    // mass and the centre of mass, into /basis: a uniform acceleration g loads q by the first
    // three columns times g (gravity), and a rigid start velocity v + w x (X - c) is q' = the
    // columns times (v, w) where the basis holds the rigid modes.
    void
    write_rigid_loads(h5::Writer &f, const NonlinearElasticity &nl, const NonlinearElasticity::RigidFields &rigid,
                      const Fields &basis)
    {
      Fields W(basis.rows(), 6);
      for (unsigned k = 0; k < 6; ++k)
        W.col(k) = Eigen::Map<const Eigen::VectorXd>(rigid.fields[k].data(), basis.rows());
      const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> G = basis.transpose() * mass_times(nl, W);
      f.write("/basis/rigid_loads", {static_cast<hsize_t>(basis.cols()), 6}, G.data());
      f.attribute("/basis", "mass_kg", rigid.mass);
      f.write("/basis/center_of_mass_m", {3}, rigid.center_of_mass.data());
    }

    // The derivatives' leading `wanted` directions by mass-weighted PCA, each derivative of
    // unit M-norm and M-orthogonal to Phi (the modes kept whole) first; their PCA values and
    // the share kept go into rep.
    Fields
    derivative_directions(const NonlinearElasticity &nl, const Fields &Phi,
                          const std::vector<std::vector<double>> &derivatives, const unsigned wanted,
                          ReducedModelReport &rep)
    {
      const Eigen::Index n = Phi.rows();
      Fields             pool(n, static_cast<Eigen::Index>(derivatives.size()));
      for (size_t k = 0; k < derivatives.size(); ++k)
        pool.col(static_cast<Eigen::Index>(k)) = Eigen::Map<const Eigen::VectorXd>(derivatives[k].data(), n);
      for (int pass = 0; pass < 2; ++pass) // twice: Gram-Schmidt against a block loses digits once
        pool -= Phi * (Phi.transpose() * mass_times(nl, pool));
      Fields out(n, wanted);
      if (wanted == 0)
        return out;
      if (pool.cols() == 0)
        throw InputError("a reduced model of more fields than the modes needs modal derivatives");
      const Fields    MP = mass_times(nl, pool);
      Eigen::VectorXd norm(pool.cols());
      for (Eigen::Index k = 0; k < pool.cols(); ++k)
        norm(k) = std::sqrt(std::max(0.0, pool.col(k).dot(MP.col(k))));
      const double largest = norm.maxCoeff();
      for (Eigen::Index k = 0; k < pool.cols(); ++k)
        norm(k) = norm(k) > 1e-12 * largest ? 1 / norm(k) : 0; // a field the modes hold: dropped
      const Eigen::MatrixXd G = norm.asDiagonal() * (pool.transpose() * MP) * norm.asDiagonal();
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (G + G.transpose()));
      const Eigen::Index n_pool = G.rows();
      double             total  = 0, kept = 0;
      for (Eigen::Index k = n_pool - 1; k >= 0; --k)
        {
          const double value = std::max(0.0, eig.eigenvalues()(k));
          rep.pool_values.push_back(value);
          total += value;
          if (n_pool - 1 - k < wanted)
            kept += value;
        }
      if (wanted > n_pool || !(rep.pool_values[wanted - 1] > 1e-10 * rep.pool_values[0]))
        throw InputError("reduced model: the derivatives hold fewer than " + std::to_string(wanted) +
                         " independent fields beyond the modes; ask for a smaller --basis");
      rep.kept_share = total > 0 ? kept / total : 1;
      for (unsigned k = 0; k < wanted; ++k)
        {
          const Eigen::Index col = n_pool - 1 - k;
          out.col(k) = pool * (norm.asDiagonal() * eig.eigenvectors().col(col)) /
                       std::sqrt(eig.eigenvalues()(col));
        }
      return out;
    }

    void
    write_mesh(h5::Writer &f, const NonlinearElasticity::ReferenceTetrahedra &tets)
    {
      f.create_group("/mesh");
      std::vector<long long> cells;
      std::vector<double>    grads;
      for (size_t e = 0; e < tets.volume.size(); ++e)
        for (int i = 0; i < 4; ++i)
          {
            cells.push_back(tets.vertices[e][i]);
            for (int d = 0; d < 3; ++d)
              grads.push_back(tets.gradients[e][i][d]);
          }
      f.write("/mesh/tetrahedra", {tets.volume.size(), 4}, cells.data());
      f.write("/mesh/gradients", {tets.volume.size(), 4, 3}, grads.data());
      f.write("/mesh/volumes", {tets.volume.size()}, tets.volume.data());
    }

    // The surface with each vertex's lumped area (a third of its triangles': the P1 FEM's
    // node-based penalty weight) and its free DoFs.
    void
    write_surface(h5::Writer &f, const SurfaceMesh &boundary, const std::vector<int> &vertex_dof_to_free)
    {
      f.create_group("/surface");
      const size_t S = boundary.mesh_vertex.size();
      std::vector<long long> vertex(S), free_dofs(3 * S);
      std::vector<double>    xyz, area(S, 0.0);
      for (size_t s = 0; s < S; ++s)
        {
          vertex[s] = boundary.mesh_vertex[s];
          for (int d = 0; d < 3; ++d)
            {
              xyz.push_back(boundary.coordinates[s][d]);
              free_dofs[3 * s + d] = vertex_dof_to_free[3 * boundary.mesh_vertex[s] + d] >= 0;
            }
        }
      std::vector<long long> tris;
      for (const auto &t : boundary.triangles)
        {
          const auto &a = boundary.coordinates[t[0]], &b = boundary.coordinates[t[1]],
                     &c = boundary.coordinates[t[2]];
          const Eigen::Vector3d ab(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
            ac(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
          const double third = ab.cross(ac).norm() / 6; // area / 3
          for (const unsigned v : t)
            {
              area[v] += third;
              tris.push_back(v);
            }
        }
      f.write("/surface/vertices", {S}, vertex.data());
      f.write("/surface/node_tags", {S}, boundary.node_tags.data());
      f.write("/surface/coordinates", {S, 3}, xyz.data());
      f.write("/surface/triangles", {boundary.triangles.size(), 3}, tris.data());
      f.write("/surface/lumped_area_m2", {S}, area.data());
      f.write("/surface/free", {S, 3}, free_dofs.data());
    }
  } // namespace

  ReducedModelReport
  precompute_reduced_model(const Scene &scene, const ReducedModelOptions &o)
  {
    const auto t_start = Clock::now();
    const auto log     = [&](const std::string &line) {
      if (o.log)
        o.log(line);
    };
    if (scene.fe_degree != 1)
      throw InputError("a reduced model needs linear (P1) elements; the scene has fe_degree " +
                       std::to_string(scene.fe_degree));
    if (o.modes < 1 || o.basis_size < o.modes)
      throw InputError("a reduced model needs at least one mode and a basis of at least --modes fields");
    if (o.derivative_modes > o.modes)
      throw InputError("--derivative-modes may not exceed --modes");
    if (o.output.empty())
      throw InputError("a reduced model needs an output file");
    // Take the output's lock before the long work.
    OutputLock lock(o.output);

    ReducedModelReport rep;
    auto               t0 = Clock::now();
    const ElasticDynamics   linear(scene);
    const std::vector<int>  vertex_dof_to_free = linear.vertex_dof_to_free();
    const SurfaceMesh       boundary           = linear.boundary();
    const unsigned          n_vertices         = static_cast<unsigned>(vertex_dof_to_free.size() / 3);
    rep.n_dofs     = linear.n_dofs();
    rep.n_free     = linear.n_free_dofs();
    rep.n_vertices = n_vertices;
    std::vector<int> rows(rep.n_free), columns;
    for (unsigned i = 0; i < rep.n_free; ++i)
      rows[i] = static_cast<int>(i);
    if (o.residual_modes)
      for (const unsigned s : select_vertices(scene.model.inputs, boundary, vertex_dof_to_free, "inputs"))
        for (int d = 0; d < 3; ++d)
          columns.push_back(vertex_dof_to_free[3 * boundary.mesh_vertex[s] + d]);
    const LowestModes lm = linear.lowest_modes(o.modes, rows, columns);
    const unsigned    n_kept = static_cast<unsigned>(lm.w2.size());
    rep.n_modes              = lm.n_lowest;
    rep.n_residual           = n_kept - lm.n_lowest;
    rep.lowest_frequency_hz  = std::sqrt(lm.w2.front()) / (2 * M_PI);
    rep.highest_frequency_hz = std::sqrt(lm.w2[lm.n_lowest - 1]) / (2 * M_PI);
    // A free body: its six rigid modes first (exact translations; rotations linearized, so
    // a large turn strains the reduced body), then the elastic and residual modes.
    const NonlinearElasticity nl(scene);
    const auto                rigid   = nl.rigid_fields();
    const unsigned            n_rigid = scene.fixed_surfaces.empty() ? 6 : 0;
    rep.n_rigid                       = n_rigid;
    Fields shapes                     = Fields::Zero(3 * n_vertices, n_rigid + n_kept);
    for (unsigned k = 0; k < n_rigid; ++k)
      shapes.col(k) = Eigen::Map<const Eigen::VectorXd>(rigid.fields[k].data(), 3 * n_vertices);
    if (n_rigid > 0)
      {
        Fields R = shapes.leftCols(n_rigid);
        mass_orthonormalize(nl, R);
        shapes.leftCols(n_rigid) = R;
      }
    for (unsigned row = 0; row < 3 * n_vertices; ++row)
      if (vertex_dof_to_free[row] >= 0)
        for (unsigned k = 0; k < n_kept; ++k)
          shapes(row, n_rigid + k) = lm.shapes[static_cast<size_t>(vertex_dof_to_free[row]) * n_kept + k];
    if (n_rigid > 0)
      rep.n_strain = append_uniform_strain_fields(nl, rigid.fields, n_vertices, shapes);
    rep.seconds_modes = since(t0);
    log("reduced model: " + std::to_string(rep.n_modes) + " lowest modes (" +
        std::to_string(rep.lowest_frequency_hz) + " to " + std::to_string(rep.highest_frequency_hz) +
        " Hz) and " + std::to_string(rep.n_residual) + " residual modes in " +
        std::to_string(rep.seconds_modes) + " s");

    t0 = Clock::now();
    std::vector<std::vector<double>> phi;
    for (unsigned k = 0; k < o.derivative_modes; ++k)
      phi.emplace_back(shapes.col(n_rigid + k).data(), shapes.col(n_rigid + k).data() + shapes.rows());
    for (unsigned k = 0; k < std::min(o.derivative_residual_modes, n_kept - lm.n_lowest); ++k)
      {
        const auto col = shapes.col(n_rigid + lm.n_lowest + k);
        phi.emplace_back(col.data(), col.data() + col.size());
      }
    const auto derivatives = nl.modal_derivatives(phi);
    rep.n_derivatives      = static_cast<unsigned>(derivatives.size());
    rep.seconds_derivatives = since(t0);
    log("reduced model: " + std::to_string(rep.n_derivatives) + " modal derivatives in " +
        std::to_string(rep.seconds_derivatives) + " s");

    // The lowest and the residual modes are kept whole (the static compliance at the inputs
    // exact); the derivatives, M-orthogonal to them and of unit M-norm, fill the rest by
    // mass-weighted PCA.
    const unsigned m     = rep.n_modes;
    const unsigned whole = n_rigid + n_kept + rep.n_strain;
    if (o.basis_size < whole)
      throw InputError("reduced model: the rigid, lowest and residual modes (and a free body's uniform strain fields) alone are " +
                       std::to_string(whole) + " fields; ask for a --basis of at least that, or "
                       "a smaller input region");
    Fields basis(3 * n_vertices, o.basis_size);
    basis.leftCols(whole) = shapes;
    basis.rightCols(o.basis_size - whole) =
      derivative_directions(nl, shapes, derivatives, o.basis_size - whole, rep);
    mass_orthonormalize(nl, basis);
    rep.basis_size = o.basis_size;

    // The file.
    const auto tets = nl.reference_tetrahedra();
    rep.n_elements  = static_cast<unsigned>(tets.volume.size());
    rep.n_surface   = static_cast<unsigned>(boundary.mesh_vertex.size());
    h5::Writer f(o.output, h5::Writer::Mode::create, std::move(lock));
    write_provenance(f, scene, IntegratorCoefficients::from_scene(scene));
    const double E = scene.youngs_modulus, nu = scene.poisson_ratio;
    f.attribute("/", "format", std::string("irdm-reduced-model"));
    f.attribute("/", "format_version", 2LL);
    f.attribute("/", "law", std::string("neo_hookean"));
    f.attribute("/", "lame_lambda_Pa", E * nu / ((1 + nu) * (1 - 2 * nu)));
    f.attribute("/", "lame_mu_Pa", E / (2 * (1 + nu)));
    f.attribute("/", "default_penalty_Pa_m", nl.default_penalty());
    f.attribute("/", "units", std::string("SI: m, s, N, kg, Pa"));
    f.attribute("/", "convention",
                std::string("u = U q at every mesh vertex; U^T M U = I (consistent mass); the FEM's "
                            "integrator at time_step_s, internal force at the alpha level"));
    f.create_group("/basis");
    {
      // Row-major [3 v + d][k].
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> U = basis;
      f.write("/basis/shapes", {3ull * n_vertices, o.basis_size}, U.data());
      std::vector<double> hz;
      for (unsigned k = 0; k < m; ++k)
        hz.push_back(std::sqrt(lm.w2[k]) / (2 * M_PI));
      f.write("/basis/lowest_frequencies_Hz", {hz.size()}, hz.data());
      if (!rep.pool_values.empty())
        f.write("/basis/pool_values", {rep.pool_values.size()}, rep.pool_values.data());
      f.attribute("/basis", "lowest_modes", static_cast<long long>(m));
      f.attribute("/basis", "residual_modes", static_cast<long long>(rep.n_residual));
      f.attribute("/basis", "modal_derivatives", static_cast<long long>(rep.n_derivatives));
      f.attribute("/basis", "derivative_modes", static_cast<long long>(o.derivative_modes));
      f.attribute("/basis", "pool_share_kept", rep.kept_share);
      f.attribute("/basis", "rigid_modes", static_cast<long long>(n_rigid));
      f.attribute("/basis", "uniform_strain_fields", static_cast<long long>(rep.n_strain));
      write_rigid_loads(f, nl, rigid, basis);
    }
    write_mesh(f, tets);
    write_surface(f, boundary, vertex_dof_to_free);
    f.commit();
    rep.seconds_total = since(t_start);
    return rep;
  }
} // namespace irdm::fem
