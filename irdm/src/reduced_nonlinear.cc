// The reduced nonlinear model's loader and its step (irdm/reduced_nonlinear.h).
#include <irdm/reduced_nonlinear.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include "element_forces.h"
#include "surface_product.h"
#include "tangent_product.h"

#include <algorithm>
#include <cmath>

namespace irdm
{
  namespace
  {
    template <class T>
    bool
    all_finite(const std::vector<T> &x)
    {
      return std::all_of(x.begin(), x.end(), [](const T v) { return std::isfinite(static_cast<double>(v)); });
    }
    // A file nobody vouches for, read by checked reads: every refusal names the file and the
    // field.
    struct Checked
    {
      const h5::Reader  &r;
      const std::string &path;

      [[noreturn]] void
      fail(const std::string &what) const
      {
        throw InputError("reduced nonlinear model '" + path + "': " + what);
      }
      // The rows of a dataset of the given trailing shape; `same_as` names the dataset whose
      // row count it must share (both named if they differ).
      hsize_t
      rows(const std::string &name, const std::vector<hsize_t> &trailing,
           const std::string &same_as = "", const hsize_t expected = 0) const
      {
        const auto shape = r.shape(name);
        if (shape.size() != trailing.size() + 1 || shape[0] == 0 || shape[0] > 100000000 ||
            !std::equal(trailing.begin(), trailing.end(), shape.begin() + 1))
          fail(name + " does not have the shape this format gives it (docs/model-format.md)");
        if (!same_as.empty() && shape[0] != expected)
          fail(name + " has " + std::to_string(shape[0]) + " rows and " + same_as + " " +
               std::to_string(expected) + ": they must be the same");
        return shape[0];
      }
    };

    // The integrator, damping, material and penalty (root attributes).
    void
    read_coefficients(const Checked &c, ReducedNonlinearModel &m)
    {
      const h5::Reader &r    = c.r;
      m.time_step       = r.double_attribute("/", "time_step_s");
      m.alpha_m         = r.double_attribute("/", "alpha_m");
      m.alpha_f         = r.double_attribute("/", "alpha_f");
      m.gamma           = r.double_attribute("/", "gamma");
      m.beta            = r.double_attribute("/", "beta");
      m.rayleigh_alpha  = r.double_attribute("/", "rayleigh_alpha_1_s");
      m.rayleigh_beta   = r.double_attribute("/", "rayleigh_beta_s");
      m.mu              = r.double_attribute("/", "lame_mu_Pa");
      m.lambda          = r.double_attribute("/", "lame_lambda_Pa");
      m.default_penalty = r.double_attribute("/", "default_penalty_Pa_m");
      m.mesh_hash       = r.string_attribute("/", "mesh_hash");
      const std::vector<std::pair<const char *, double>> positive = {
        {"time_step_s", m.time_step}, {"lame_mu_Pa", m.mu}, {"default_penalty_Pa_m", m.default_penalty},
        {"beta", m.beta}};
      for (const auto &[name, x] : positive)
        if (!(std::isfinite(x) && x > 0))
          c.fail(std::string(name) + " must be finite and positive");
      const std::vector<std::pair<const char *, double>> non_negative = {
        {"alpha_f", m.alpha_f}, {"gamma", m.gamma}, {"rayleigh_alpha_1_s", m.rayleigh_alpha},
        {"rayleigh_beta_s", m.rayleigh_beta}, {"lame_lambda_Pa", m.lambda}};
      for (const auto &[name, x] : non_negative)
        if (!(std::isfinite(x) && x >= 0))
          c.fail(std::string(name) + " must be finite and not negative");
      if (!(std::isfinite(m.alpha_m) && m.alpha_m < 1))
        c.fail("alpha_m must be finite and below 1");
      if (!(m.alpha_f < 1))
        c.fail("alpha_f must be below 1");
    }

    // The basis and the P1 cells.
    void
    read_basis_and_mesh(const Checked &c, const long long version, ReducedNonlinearModel &m)
    {
      const h5::Reader &r    = c.r;
      const auto shape = r.shape("/basis/shapes");
      if (shape.size() != 2 || shape[0] % 3 != 0 || shape[0] == 0 || shape[1] == 0 || shape[1] > 10000 ||
          shape[0] > 300000000ull / shape[1])
        c.fail("/basis/shapes must be (3 x vertices) x r with 1 <= r <= 10000");
      m.n_vertices = static_cast<unsigned>(shape[0] / 3);
      m.size       = static_cast<unsigned>(shape[1]);
      m.basis      = r.read_double("/basis/shapes", shape);
      if (!all_finite(m.basis))
        c.fail("/basis/shapes is not finite");
      m.lowest_modes      = static_cast<unsigned>(r.count_attribute("/basis", "lowest_modes", 0, m.size));
      m.residual_modes    = static_cast<unsigned>(r.count_attribute("/basis", "residual_modes", 0, 100000000));
      m.modal_derivatives = static_cast<unsigned>(r.count_attribute("/basis", "modal_derivatives", 0, 100000000));
      // Version 2: the rigid modes (a free body's) and the rigid fields' loads.
      if (version >= 2)
        {
          if (!r.exists("/basis/rigid_loads"))
            c.fail("/basis/rigid_loads is missing (format version 2 has it)");
          m.rigid_modes = static_cast<unsigned>(r.count_attribute("/basis", "rigid_modes", 0, 6));
          if (r.has_attribute("/basis", "uniform_strain_fields"))
            m.uniform_strain_fields =
              static_cast<unsigned>(r.count_attribute("/basis", "uniform_strain_fields", 0, 6));
          if ((m.rigid_modes != 0 && m.rigid_modes != 6) || m.rigid_modes > m.size)
            c.fail("/basis: rigid_modes must be 0 or 6, and at most the basis's fields");
          c.rows("/basis/rigid_loads", {6}, "/basis/shapes (columns)", m.size);
          m.rigid_loads = r.read_double("/basis/rigid_loads", {m.size, 6});
          m.mass        = r.double_attribute("/basis", "mass_kg");
          if (r.shape("/basis/center_of_mass_m") != std::vector<hsize_t>{3})
            c.fail("/basis/center_of_mass_m must hold 3 values");
          const auto com = r.read_double("/basis/center_of_mass_m", {3});
          if (!all_finite(m.rigid_loads) || !all_finite(com) || !(std::isfinite(m.mass) && m.mass > 0))
            c.fail("/basis: rigid_loads, mass_kg and center_of_mass_m must be finite, the mass positive");
          m.center_of_mass = {com[0], com[1], com[2]};
        }

      const size_t E     = c.rows("/mesh/tetrahedra", {4});
      c.rows("/mesh/gradients", {4, 3}, "/mesh/tetrahedra", E);
      c.rows("/mesh/volumes", {}, "/mesh/tetrahedra", E);
      const auto   tets  = r.read_int("/mesh/tetrahedra", {E, 4});
      const auto   grads = r.read_double("/mesh/gradients", {E, 4, 3});
      const auto   vols  = r.read_double("/mesh/volumes", {E});
      if (!all_finite(grads))
        c.fail("/mesh/gradients is not finite");
      m.tetrahedra.resize(E);
      m.elements.resize(E);
      for (size_t e = 0; e < E; ++e)
        {
          if (!(std::isfinite(vols[e]) && vols[e] > 0))
            c.fail("/mesh/volumes: element " + std::to_string(e) + " has no finite positive volume");
          m.elements[e].volume = vols[e];
          for (int i = 0; i < 4; ++i)
            {
              const long long v = tets[4 * e + i];
              if (v < 0 || v >= static_cast<long long>(m.n_vertices))
                c.fail("/mesh/tetrahedra: element " + std::to_string(e) + " names a vertex the basis does not have");
              m.tetrahedra[e][i] = static_cast<unsigned>(v);
              for (int d = 0; d < 3; ++d)
                m.elements[e].grad(d, i) = grads[12 * e + 3 * i + d];
            }
        }
    }

    // The cubature, or every element with weight 1.
    void
    read_cubature(const Checked &c, ReducedNonlinearModel &m)
    {
      const h5::Reader &r    = c.r;
      const size_t      E    = m.elements.size();
      if (r.exists("/cubature"))
        {
          const hsize_t n = c.rows("/cubature/elements", {});
          if (n > E)
            c.fail("/cubature/elements lists more elements than the mesh has");
          c.rows("/cubature/weights", {}, "/cubature/elements", n);
          const auto ids       = r.read_int("/cubature/elements", {n});
          m.cubature_weights   = r.read_double("/cubature/weights", {n});
          m.cubature_training_error = r.double_attribute("/cubature", "training_error");
          for (size_t k = 0; k < n; ++k)
            {
              if (ids[k] < 0 || ids[k] >= static_cast<long long>(E))
                c.fail("/cubature/elements: an element that is not one of the mesh's");
              if (!(std::isfinite(m.cubature_weights[k]) && m.cubature_weights[k] >= 0))
                c.fail("/cubature/weights: a weight is negative or not finite");
              m.cubature_elements.push_back(static_cast<unsigned>(ids[k]));
            }
          m.every_element = false;
        }
      else
        {
          for (unsigned e = 0; e < E; ++e)
            m.cubature_elements.push_back(e);
          m.cubature_weights.assign(E, 1.0);
        }
    }

    // The surface: vertices, tags, positions, triangles, lumped areas and free DoFs.
    void
    read_surface(const Checked &c, ReducedNonlinearModel &m)
    {
      const h5::Reader &r    = c.r;
      const size_t S = c.rows("/surface/vertices", {});
      if (S > m.n_vertices)
        c.fail("/surface/vertices lists more vertices than the basis has");
      c.rows("/surface/node_tags", {}, "/surface/vertices", S);
      c.rows("/surface/coordinates", {3}, "/surface/vertices", S);
      c.rows("/surface/lumped_area_m2", {}, "/surface/vertices", S);
      c.rows("/surface/free", {3}, "/surface/vertices", S);
      const auto   ids  = r.read_int("/surface/vertices", {S});
      m.node_tags       = r.read_int("/surface/node_tags", {S});
      const auto xyz    = r.read_double("/surface/coordinates", {S, 3});
      m.lumped_area     = r.read_double("/surface/lumped_area_m2", {S});
      const auto free   = r.read_int("/surface/free", {S, 3});
      const hsize_t n_triangles = c.rows("/surface/triangles", {3});
      const auto    tris        = r.read_int("/surface/triangles", {n_triangles, 3});
      if (!all_finite(xyz) || !all_finite(m.lumped_area))
        c.fail(!all_finite(xyz) ? "/surface/coordinates is not finite" : "/surface/lumped_area_m2 is not finite");
      for (size_t s = 0; s < S; ++s)
        {
          if (ids[s] < 0 || ids[s] >= static_cast<long long>(m.n_vertices))
            c.fail("/surface/vertices: a vertex the basis does not have");
          if (m.lumped_area[s] < 0)
            c.fail("/surface/lumped_area_m2: a negative area");
          m.surface_vertex.push_back(static_cast<unsigned>(ids[s]));
          m.coordinates.push_back({xyz[3 * s], xyz[3 * s + 1], xyz[3 * s + 2]});
          m.free_dof.push_back({free[3 * s] != 0, free[3 * s + 1] != 0, free[3 * s + 2] != 0});
        }
      for (size_t t = 0; t < n_triangles; ++t)
        {
          std::array<unsigned, 3> tri{};
          for (int i = 0; i < 3; ++i)
            {
              if (tris[3 * t + i] < 0 || tris[3 * t + i] >= static_cast<long long>(S))
                c.fail("/surface/triangles: a vertex the surface does not have");
              tri[i] = static_cast<unsigned>(tris[3 * t + i]);
            }
          m.triangles.push_back(tri);
        }
    }
  } // namespace

  ReducedNonlinearModel
  load_reduced_nonlinear_model(const std::string &path, const double expected_time_step)
  {
    const h5::Reader r(path);
    const Checked    c{r, path};
    if (!r.has_attribute("/", "format") || r.string_attribute("/", "format") != "irdm-reduced-model")
      c.fail("not a reduced nonlinear model (attribute 'format' is missing or different)");
    const long long version = r.count_attribute("/", "format_version", 0, 1000);
    if (version != 1 && version != 2)
      c.fail("format_version is not 1 or 2 (this program reads versions 1 and 2)");
    if (r.string_attribute("/", "law") != "neo_hookean")
      c.fail("law '" + r.string_attribute("/", "law") + "' is not one this runtime knows (neo_hookean)");
    ReducedNonlinearModel m;
    m.path = path;
    read_coefficients(c, m);
    if (expected_time_step > 0 && std::abs(m.time_step - expected_time_step) > 1e-12 * expected_time_step)
      c.fail("its time step differs from the scene's");
    read_basis_and_mesh(c, version, m);
    read_cubature(c, m);
    read_surface(c, m);
    return m;
  }

  Eigen::Map<const Eigen::RowVectorXd>
  ReducedNonlinearBody::basis_row(const unsigned v, const int d) const
  {
    return Eigen::Map<const Eigen::RowVectorXd>(&m_.basis[(3 * static_cast<size_t>(v) + d) * r_], r_);
  }

  void
  ReducedNonlinearBody::prepare_cubature()
  {
    // The distinct vertices, in the mesh's order, and each element's among them.
    std::vector<unsigned> &local = vertex_local_;
    local.assign(m_.n_vertices, ~0u);
    unsigned n_local = 0;
    for (const unsigned e : m_.cubature_elements)
      for (const unsigned v : m_.tetrahedra[e])
        local[v] = 0;
    std::vector<unsigned> vertices;
    for (unsigned v = 0; v < m_.n_vertices; ++v)
      if (local[v] == 0)
        local[v] = n_local++, vertices.push_back(v);
    vertex_basis_.resize(3 * Eigen::Index(n_local), r_);
    for (unsigned i = 0; i < n_local; ++i)
      for (int d = 0; d < 3; ++d)
        vertex_basis_.row(3 * Eigen::Index(i) + d) =
          basis_row(vertices[i], d);
    for (size_t k = 0; k < m_.cubature_elements.size(); ++k)
      {
        const unsigned e = m_.cubature_elements[k];
        element_vertices_.push_back({local[m_.tetrahedra[e][0]], local[m_.tetrahedra[e][1]],
                                     local[m_.tetrahedra[e][2]], local[m_.tetrahedra[e][3]]});
        element_.push_back(m_.elements[e]);
        weight_.push_back(m_.cubature_weights[k]);
      }
    // The block CSR of the vertex pairs the elements couple, and each element's places in it.
    std::vector<std::vector<unsigned>> columns(n_local);
    for (const auto &t : element_vertices_)
      for (const unsigned a : t)
        for (const unsigned b : t)
          columns[a].push_back(b);
    block_row_start_.assign(1, 0);
    for (auto &c : columns)
      {
        std::sort(c.begin(), c.end());
        c.erase(std::unique(c.begin(), c.end()), c.end());
        block_column_.insert(block_column_.end(), c.begin(), c.end());
        block_row_start_.push_back(static_cast<unsigned>(block_column_.size()));
      }
    for (const auto &t : element_vertices_)
      {
        std::array<unsigned, 16> places{};
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b)
            {
              const auto first = block_column_.begin() + block_row_start_[t[a]],
                         last  = block_column_.begin() + block_row_start_[t[a] + 1];
              places[4 * a + b] = static_cast<unsigned>(std::lower_bound(first, last, t[b]) - block_column_.begin());
            }
        element_blocks_.push_back(places);
      }
    stiffness_blocks_.assign(block_column_.size(), Eigen::Matrix3d::Zero());
    element_lanes_ = detail::pack_element_lanes(element_, weight_, element_vertices_);
    if (options_.single_precision_rows) // the double rows rounded too: the residual, the planes and the tangent read one basis
      {
        vertex_rows_  = vertex_basis_.cast<float>();
        vertex_basis_ = vertex_rows_.cast<double>();
      }
    for (Vector *x : {&vertex_u_, &vertex_v_, &vertex_f_, &vertex_x_, &vertex_q_, &vertex_w_, &staged_u_, &staged_v_})
      x->setZero(3 * Eigen::Index(n_local));
    if (options_.single_precision_rows)
      KU_rows_.setZero(3 * Eigen::Index(n_local), r_), tangent_rows_.setZero(r_, r_);
    else
      KU_.setZero(3 * Eigen::Index(n_local), r_), KU_row_.setZero(3, r_);
    // Eigen's product keeps its packed operands on the stack up to EIGEN_STACK_ALLOCATION_LIMIT
    // (128 KiB): a slice of s rows packs at most s r doubles of each (its blocks are at most the
    // slice deep and r wide); (r + 16) s doubles within 96 KiB leaves room. Past r = 4096 the
    // floor of 3 rows exceeds it and the product's work space goes to the heap.
    slice_ = std::max<Eigen::Index>(3, (96 * 1024 / 8) / (Eigen::Index(r_) + 16) / 3 * 3);
  }

  ReducedNonlinearBody::ReducedNonlinearBody(const ReducedNonlinearModel &model,
                                             const ReducedBodyOptions    &options)
    : m_(model)
    , options_(options)
    , r_(model.size)
    , h_(model.time_step)
    , solver_(model.size) // sized once here: an LDLT assigned later reads its unset status
  {
    prepare_cubature();
    for (unsigned s = 0; s < m_.surface_vertex.size(); ++s)
      {
        const auto &free = m_.free_dof[s];
        if (free[0] || free[1] || free[2]) // not a fixed vertex: a plane's push on that goes into the support
          surface_index_.push_back(s);
      }
    surface_basis_.resize(3 * Eigen::Index(surface_index_.size()), r_);
    for (size_t k = 0; k < surface_index_.size(); ++k)
      {
        const unsigned s    = surface_index_[k];
        const auto    &free = m_.free_dof[s];
        for (int d = 0; d < 3; ++d)
          surface_basis_.row(3 * Eigen::Index(k) + d) = free[d] ? Eigen::RowVectorXd(basis_row(m_.surface_vertex[s], d)) : Eigen::RowVectorXd::Zero(r_);
        surface_rest_.emplace_back(m_.coordinates[s][0], m_.coordinates[s][1], m_.coordinates[s][2]);
        surface_area_.push_back(m_.lumped_area[s]);
      }
    if (options_.single_precision_rows)
      surface_basis_ = surface_basis_.cast<float>().cast<double>();
    for (size_t k = 0; k < surface_index_.size(); ++k)
      {
        const unsigned v = vertex_local_[m_.surface_vertex[surface_index_[k]]];
        if (v != ~0u && surface_rows(k) == vertex_basis_.middleRows<3>(3 * Eigen::Index(v)))
          surface_shared_.push_back({static_cast<unsigned>(k), v});
        else
          surface_other_.push_back(static_cast<unsigned>(k));
      }
    surface_other_basis_.resize(3 * Eigen::Index(surface_other_.size()), r_);
    for (size_t i = 0; i < surface_other_.size(); ++i)
      surface_other_basis_.middleRows<3>(3 * Eigen::Index(i)) = surface_rows(surface_other_[i]);
    if (options_.single_precision_rows)
      surface_other_rows_ = surface_other_basis_.cast<float>();
    surface_other_u_.setZero(surface_other_basis_.rows());
    surface_u_.setZero(surface_basis_.rows());
    for (Vector *x : {&q_, &v_, &a_, &w_, &g_c_, &x_, &a1_, &v1_, &q_af_, &v_af_, &residual_, &trial_,
                      &r_trial_, &dq_, &g_c_trial_, &best_, &g_int_, &Un_, &g_f_, &g_f_new_, &g_f_end_, &body_force_, &q0_, &v0_, &a0_, &g_c0_, &g_f0_})
      x->setZero(r_);
    for (Matrix *T : {&body_tangent_, &contact_tangent_, &tangent_, &staged_tangent_})
      T->setZero(r_, r_);
    for (auto &B : probe_basis_)
      B.setZero(3, r_);
    for (auto &B : key_probe_basis_)
      B.setZero(3, r_);
    point_basis_.setZero(3, r_);
    point_solve_.setZero(r_, 3);
    contact_vertex_.assign(surface_index_.size() * max_planes, 0);
    contact_plane_.assign(contact_vertex_.size(), 0);
    contact_weight_.assign(contact_vertex_.size(), 0);
    key_vertex_.assign(contact_vertex_.size(), 0);
    key_weight_.assign(contact_vertex_.size(), 0);
    key_normal_.assign(contact_vertex_.size(), {0, 0, 0});
    contact_force_.assign(surface_index_.size() * max_planes, Eigen::Vector3d::Zero());
    center0_      = Eigen::Vector3d(m_.center_of_mass[0], m_.center_of_mass[1], m_.center_of_mass[2]);
    frame_origin_ = center0_;
    floating_     = options_.floating_frame && m_.rigid_modes == 6;
    if (floating_)
      prepare_frame();
  }

  void
  ReducedNonlinearBody::prepare_frame()
  {
    using Strided = Eigen::Map<const RowMatrix, 0, Eigen::OuterStride<>>;
    const auto fail = [&](const std::string &what) {
      throw InputError("reduced nonlinear model '" + m_.path + "': " + what +
                       "; its body cannot move in a floating frame (ReducedBodyOptions::floating_frame)");
    };
    if (m_.uniform_strain_fields != 6)
      fail("its basis does not hold the six uniform strain fields (a model made before them: make it "
           "again), without which each step's turn leaves its arc out and the spin gains energy");
    const Eigen::Index n = m_.n_vertices, r = r_;
    double             volume = 0;
    for (const auto &e : m_.elements)
      volume += e.volume;
    const double rho = m_.mass / volume;
    // M_s U: the P1 consistent mass, rho V (1 + delta_ij) / 20 per element, on each vertex's
    // three rows at once (M = M_s (x) I_3).
    const Eigen::Map<const RowMatrix> U(m_.basis.data(), 3 * n, r);
    RowMatrix                         MU = RowMatrix::Zero(3 * n, r);
    for (size_t e = 0; e < m_.elements.size(); ++e)
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
          MU.middleRows(3 * Eigen::Index(m_.tetrahedra[e][i]), 3) +=
            (rho * m_.elements[e].volume * (i == j ? 2 : 1) / 20) * U.middleRows(3 * Eigen::Index(m_.tetrahedra[e][j]), 3);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        {
          const Strided Ua(m_.basis.data() + a * r, n, r, Eigen::OuterStride<>(3 * r));
          const Strided MUb(MU.data() + b * r, n, r, Eigen::OuterStride<>(3 * r));
          J_[3 * a + b] = Ua.transpose() * MUb;
        }
    const double orthonormal = (J_[0] + J_[4] + J_[8] - Matrix::Identity(r, r)).cwiseAbs().maxCoeff();
    if (!(orthonormal <= 1e-6))
      fail("its basis is not orthonormal in the consistent mass of its mesh at one density (U^T M U - I "
           "reaches " + std::to_string(orthonormal) + ")");
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> G(m_.rigid_loads.data(), r, 6);
    translation_loads_.resize(r, 3);
    for (int a = 0; a < 3; ++a)
      translation_loads_.col(a) =
        Strided(MU.data() + a * r, n, r, Eigen::OuterStride<>(3 * r)).transpose() * Eigen::VectorXd::Ones(n);
    if (!((translation_loads_ - G.leftCols<3>()).norm() <= 1e-6 * G.leftCols<3>().norm()))
      fail("its rigid_loads are not U^T M 1 for its mesh's mass");
    if (!(G.bottomRows(r - 6).norm() <= 1e-6 * G.topRows<6>().norm()))
      fail("its fields after the first six are not M-orthogonal to the rigid ones");
    const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(G.topRows<6>());
    if (lu.rank() < 6)
      fail("its first six fields do not span the rigid motions");
    rigid_inverse_  = lu.inverse();
    rotation_loads_ = G.rightCols<3>();
    // [e_j]x has entries eps_ajb: U^T M (e_j x U c) = sum_ab eps_ajb J_ab c.
    const auto eps = [](const int a, const int b, const int c) { return double((a - b) * (b - c) * (c - a)) / 2; };
    turned_rotation_.setZero(r, 9);
    for (int j = 0; j < 3; ++j)
      {
        Matrix Gj = Matrix::Zero(r, r);
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            if (eps(a, j, b) != 0)
              Gj += eps(a, j, b) * J_[3 * a + b];
        for (int i = 0; i < 3; ++i)
          turned_rotation_.col(3 * i + j) = Gj * rotation_loads_.col(i);
      }
    for (const auto &x : surface_rest_)
      size_ = std::max(size_, (x - center0_).norm());
    P_.setZero(r, r);
    carried_.setZero(r);
    momentum_map_.setZero(r, 3);
    momentum_work_.setZero(r);
  }

  void
  ReducedNonlinearBody::angular_momentum_map(const Vector &q) const
  {
    const Eigen::Vector3d shift = translation_loads_.transpose() * q / m_.mass;
    for (int k = 0; k < 3; ++k)
      {
        const int a = (k + 1) % 3, b = (k + 2) % 3;
        auto      Ak = momentum_map_.col(k);
        Ak           = rotation_loads_.col(k);
        momentum_work_.noalias() = J_[3 * b + a] * q;
        Ak += momentum_work_;
        momentum_work_.noalias() = J_[3 * a + b] * q;
        Ak -= momentum_work_;
        Ak.noalias() -= translation_loads_ * Eigen::Vector3d::Unit(k).cross(shift);
      }
  }

  void
  ReducedNonlinearBody::planes_to_body(ReducedPlane *planes, const int n) const
  {
    const Eigen::Matrix3d Rt = frame_rotation_.transpose();
    for (int p = 0; p < n; ++p)
      {
        const Eigen::Vector3d normal = Rt * Eigen::Vector3d(planes[p].normal[0], planes[p].normal[1], planes[p].normal[2]);
        const Eigen::Vector3d point =
          center0_ + Rt * (Eigen::Vector3d(planes[p].point[0], planes[p].point[1], planes[p].point[2]) - frame_origin_);
        for (int d = 0; d < 3; ++d)
          planes[p].normal[d] = normal(d), planes[p].point[d] = point(d);
      }
  }

  void
  ReducedNonlinearBody::carry_into_new_frame(const ReducedVertexForce *forces, const int n_forces)
  {
    // The new frame in the step's: moved by ts and turned by Rs, so a point at y in the
    // step's frame is at Q (y - ts) in the new one (about c0), Q = Rs^T. Its rigid
    // coordinates in the new frame are made zero by a few corrections (the first finds the
    // step's rigid motion, the next what is left of its second order).
    Eigen::Matrix3d Rs = Eigen::Matrix3d::Identity();
    Eigen::Vector3d ts = Eigen::Vector3d::Zero();
    carried_           = q_;
    for (int it = 0; it < 4; ++it)
      {
        const Eigen::Matrix<double, 6, 1> d = rigid_inverse_ * carried_.head<6>();
        const Eigen::Vector3d t = d.head<3>(), theta = d.tail<3>();
        if (it > 0 && theta.norm() <= 1e-14 && t.norm() <= 1e-14 * size_)
          break;
        ts += Rs * t;
        if (theta.norm() > 0)
          Rs = Rs * Eigen::AngleAxisd(theta.norm(), theta.normalized()).toRotationMatrix();
        const Eigen::Matrix3d Q = Rs.transpose();
        // u' = Q (X~ + u - ts) - X~ on the basis: U^T M (Q u) = P(Q) q, and (Q - I) X~ =
        // sin(phi) k x X~ + (1 - cos(phi)) k x (k x X~) for Q = exp(phi [k]x), both rotations
        // of the rigid rotation field k x X~, which the basis holds.
        P_.setZero();
        for (int a = 0; a < 9; ++a)
          P_ += Q(a / 3, a % 3) * J_[a];
        const Eigen::AngleAxisd turn(Q);
        const Eigen::Vector3d   k = turn.axis();
        carried_.noalias() = P_ * q_;
        carried_.noalias() += std::sin(turn.angle()) * (rotation_loads_ * k);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            carried_ += ((1 - std::cos(turn.angle())) * k(i) * k(j)) * turned_rotation_.col(3 * i + j);
        carried_.noalias() -= translation_loads_ * (Q * ts);
      }
    carried_.head<6>().setZero();
    q_.swap(carried_);
    // The velocity and the acceleration: the world's fields turned into the new frame (an
    // inertial frame for the next step, as this one was for this step).
    dq_.noalias() = P_ * v_;
    v_.swap(dq_);
    dq_.noalias() = P_ * a_;
    a_.swap(dq_);
    const Eigen::Matrix3d Q = Rs.transpose();
    g_c_.setZero();
    Eigen::Vector3d       torque     = Eigen::Vector3d::Zero();
    const Eigen::Vector3d arm_origin = center0_ + translation_loads_.transpose() * q_ / m_.mass;
    for (size_t c = 0; c < n_contacts_; ++c)
      {
        const unsigned        s = contact_vertex_[c];
        const Eigen::Vector3d f = Q * contact_force_[c];
        const auto            U = surface_rows(s);
        g_c_.noalias() += U.transpose() * f;
        torque += (surface_rest_[s] + U * q_ - arm_origin).cross(f);
      }
    if (options_.keep_angular_momentum) // what the carried forces' projection misses of their torque
      {
        angular_momentum_map(q_);
        contact_leak_ = torque - momentum_map_.transpose() * g_c_;
      }
    frame_origin_ += frame_rotation_ * ts;
    Eigen::Quaterniond turned(frame_rotation_ * Rs);
    turned.normalize();
    frame_rotation_ = turned.toRotationMatrix();
    body_force_.noalias() = translation_loads_ * (frame_rotation_.transpose() * gravity_);
    vertex_load(forces, n_forces, g_f_, frame_rotation_.transpose());
    g_f_ += body_force_;
  }

  bool
  ReducedNonlinearBody::vertex_load(const ReducedVertexForce *forces, const int n, Vector &g,
                                    const Eigen::Matrix3d &to_body) const
  {
    g.setZero();
    for (int i = 0; i < n; ++i)
      {
        const unsigned s = forces[i].vertex;
        if (s >= m_.surface_vertex.size())
          return false;
        const Eigen::Vector3d f = to_body * Eigen::Vector3d(forces[i].force[0], forces[i].force[1], forces[i].force[2]);
        if (!f.allFinite())
          return false;
        for (int d = 0; d < 3; ++d)
          if (m_.free_dof[s][d])
            g += f(d) * basis_row(m_.surface_vertex[s], d).transpose();
      }
    return true;
  }

  bool
  ReducedNonlinearBody::start(const std::array<double, 3> &gravity, const std::array<double, 3> &velocity,
                              const std::array<double, 3> &spin, const ReducedVertexForce *forces,
                              const int n_forces)
  {
    const bool moving = velocity != std::array<double, 3>{} || spin != std::array<double, 3>{};
    if (stepped_ || m_.rigid_loads.size() != 6 * size_t(r_) || (moving && m_.rigid_modes == 0) ||
        n_forces < 0 || (n_forces > 0 && !forces) || !vertex_load(forces, n_forces, g_f_end_))
      return false;
    for (int d = 0; d < 3; ++d)
      if (!std::isfinite(gravity[d]) || !std::isfinite(velocity[d]) || !std::isfinite(spin[d]))
        return false;
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> G(m_.rigid_loads.data(), r_, 6);
    const Eigen::Vector3d g(gravity[0], gravity[1], gravity[2]);
    Eigen::Matrix<double, 6, 1> vw;
    vw << velocity[0], velocity[1], velocity[2], spin[0], spin[1], spin[2];
    gravity_    = g;
    body_force_ = G.leftCols<3>() * g;
    g_f_        = body_force_ + g_f_end_;
    v_          = G * vw;
    a_          = body_force_ - m_.rayleigh_alpha * v_;
    return true;
  }

  bool
  ReducedNonlinearBody::patch_basis(const unsigned *vertices, const double *weights, const int n,
                                    Eigen::Matrix<double, 3, Eigen::Dynamic> &B) const
  {
    if (n < 1 || n > ReducedProbe::max_patch || !vertices || !weights)
      return false;
    B.setZero();
    for (int i = 0; i < n; ++i)
      {
        const unsigned s = vertices[i];
        if (s >= m_.surface_vertex.size() || !std::isfinite(weights[i]))
          return false;
        for (int d = 0; d < 3; ++d)
          if (m_.free_dof[s][d])
            B.row(d) += weights[i] * basis_row(m_.surface_vertex[s], d);
      }
    return true;
  }

  std::array<double, 3>
  ReducedNonlinearBody::probe_displacement(const int p) const
  {
    const Eigen::Vector3d u = probe_basis_[p] * q_;
    return {u(0), u(1), u(2)};
  }

  bool
  ReducedNonlinearBody::point_state(const unsigned *vertices, const double *weights, const int n,
                                    double u[3], double v[3], double a[3], double W[9])
  {
    if (floating_ || factorized_h_ != m_.time_step || !patch_basis(vertices, weights, n, point_basis_))
      return false;
    point_solve_ = solver_.solve(point_basis_.transpose());
    const Eigen::Matrix3d C = (1 - m_.alpha_f) * (point_basis_ * point_solve_);
    const Eigen::Vector3d x = point_basis_ * q_, xd = point_basis_ * v_, xdd = point_basis_ * a_;
    for (int i = 0; i < 3; ++i)
      {
        u[i] = x(i), v[i] = xd(i), a[i] = xdd(i);
        for (int j = 0; j < 3; ++j)
          W[3 * i + j] = 0.5 * (C(i, j) + C(j, i));
      }
    return true;
  }

  void
  ReducedNonlinearBody::part_start_rows()
  {
    // w = v_af at x = q: a1 = -v / (beta h) - (1 / (2 beta) - 1) a, v1 = v + h ((1 - gamma) a
    // + gamma a1) = (1 - gamma / beta) v + h (1 - gamma / (2 beta)) a, w = (1 - af) v1 + af v.
    const double h = h_, af = m_.alpha_f, b = m_.beta, g = m_.gamma;
    w_ = ((1 - af) * (1 - g / b) + af) * v_ + ((1 - af) * h * (1 - g / (2 * b))) * a_;
    const auto rows = static_cast<std::size_t>(vertex_basis_.rows());
    if (options_.single_precision_rows)
      detail::rows_product2(vertex_rows_.data(), r_, rows, q_.data(), w_.data(), vertex_q_.data(),
                            vertex_w_.data());
    else
      vertex_q_.noalias() = vertex_basis_ * q_, vertex_w_.noalias() = vertex_basis_ * w_;
    if (stage_at_start_ && h_ == m_.time_step)
      stage_tangent();
    stage_at_start_ = false;
  }

  bool
  ReducedNonlinearBody::internal_force(const Vector &x, Matrix *T, const double af, const double c_c)
  {
    // Every cubature vertex's displacement and velocity, from one product (U x) and the
    // part's start; the elements then gather theirs and give back their forces, assembled by
    // vertex.
    const bool damped = m_.rayleigh_beta != 0;
    const auto rows = static_cast<std::size_t>(vertex_basis_.rows());
    if (options_.single_precision_rows)
      detail::rows_product(vertex_rows_.data(), r_, rows, x.data(), vertex_x_.data());
    else
      vertex_x_.noalias() = vertex_basis_ * x;
    vertex_u_ = (1 - af) * vertex_x_ + af * vertex_q_;
    if (damped) // c_c = (1 - af) gamma / (beta h): v_af's rate in x
      vertex_v_ = c_c * (vertex_x_ - vertex_q_) + vertex_w_;
    // Every element's force by the four-lane kernel, with the tangent or without (a residual
    // rounds alike either way); the one-element kernels give the tangent's K and D.
    vertex_f_.setZero();
    const bool ok = detail::damped_neo_hookean_forces(element_lanes_.data(), element_lanes_.size(), vertex_u_.data(),
                                                      vertex_v_.data(), m_.mu, m_.lambda, m_.rayleigh_beta,
                                                      vertex_f_.data()) == 0;
    if (T)
      element_stiffness(vertex_u_, vertex_v_, af, c_c, 0, element_.size());
    if (options_.single_precision_rows)
      detail::transposed_rows_product(vertex_rows_.data(), r_, rows, vertex_f_.data(), g_int_.data());
    else
      g_int_.noalias() = vertex_basis_.transpose() * vertex_f_;
    if (T)
      {
        begin_tangent_sum();
        tangent_rows(0, block_row_start_.size() - 1, *T);
        end_tangent_sum(*T);
      }
    return ok;
  }

  bool
  ReducedNonlinearBody::residual(const Vector &x, const ReducedPlane *planes, const int n,
                                 Vector &res, Matrix *T, Matrix *C, Vector &g_c,
                                 std::array<std::array<double, 3>, max_planes> &force,
                                 std::array<int, max_planes> &vertices)
  {
    const double h = h_, am = m_.alpha_m, af = m_.alpha_f, b = m_.beta, g = m_.gamma;
    // Newmark's acceleration and velocity at q_1 = x, and the alpha levels.
    a1_   = (x - q_ - h * v_) / (b * h * h) - (1 / (2 * b) - 1) * a_;
    v1_   = v_ + h * ((1 - g) * a_ + g * a1_);
    q_af_ = (1 - af) * x + af * q_;
    v_af_ = (1 - af) * v1_ + af * v_;
    const double c_m = (1 - am) / (b * h * h), c_c = (1 - af) * g / (b * h);
    res = (1 - am) * a1_ + am * a_ + m_.rayleigh_alpha * v_af_;
    scale_ = res.norm();
    if (T)
      {
        T->setZero();
        T->diagonal().setConstant(c_m + c_c * m_.rayleigh_alpha);
      }
    const bool ok = internal_force(x, T, af, c_c);
    // The planes' penalty at the surface vertices (the FEM's P1 rule: each vertex's lumped
    // area, force k A g n where it has passed the plane by g).
    g_c.setZero();
    n_contacts_ = 0;
    // Arms from the centre of mass at x, for the planes' torque (a floating body's).
    const Eigen::Vector3d arm_origin = floating_ ? Eigen::Vector3d(center0_ + translation_loads_.transpose() * x / m_.mass)
                                                 : Eigen::Vector3d::Zero();
    contact_torque_trial_.setZero();
    if (n > 0)
      {
        for (const auto &[k, v] : surface_shared_)
          surface_u_.segment<3>(3 * Eigen::Index(k)) = vertex_x_.segment<3>(3 * Eigen::Index(v));
        if (options_.single_precision_rows)
          detail::rows_product(surface_other_rows_.data(), r_, static_cast<std::size_t>(surface_other_rows_.rows()),
                               x.data(), surface_other_u_.data());
        else
          surface_other_u_.noalias() = surface_other_basis_ * x;
        for (size_t i = 0; i < surface_other_.size(); ++i)
          surface_u_.segment<3>(3 * Eigen::Index(surface_other_[i])) = surface_other_u_.segment<3>(3 * Eigen::Index(i));
      }
    for (int p = 0; p < n; ++p)
      {
        force[p]    = {0, 0, 0};
        vertices[p] = 0;
        const Eigen::Vector3d normal(planes[p].normal[0], planes[p].normal[1], planes[p].normal[2]);
        const Eigen::Vector3d point(planes[p].point[0], planes[p].point[1], planes[p].point[2]);
        const double          k = planes[p].penalty > 0 ? planes[p].penalty : m_.default_penalty;
        const double          rest_gap_bound = normal.dot(point);
        for (size_t s = 0; s < surface_index_.size(); ++s)
          {
            const auto            U  = surface_rows(s);
            const Eigen::Vector3d xs = surface_rest_[s] + surface_u_.segment<3>(3 * Eigen::Index(s));
            const double          depth = rest_gap_bound - normal.dot(xs);
            if (depth <= 0)
              continue;
            const double          ka = planes[p].stiffness > 0 ? planes[p].stiffness : k * surface_area_[s];
            const Eigen::Vector3d f  = ka * depth * normal;
            const auto           &free = m_.free_dof[surface_index_[s]];
            for (int d = 0; d < 3; ++d)
              if (free[d])
                force[p][d] += f(d);
            ++vertices[p];
            contact_vertex_[n_contacts_]  = static_cast<unsigned>(s);
            contact_plane_[n_contacts_]   = p;
            contact_weight_[n_contacts_]  = (1 - af) * ka;
            contact_force_[n_contacts_++] = f;
            g_c.noalias() += U.transpose() * f;
            contact_torque_trial_ += (xs - arm_origin).cross(f);
          }
      }
    // The probes' couplings at the step's end: spring and damper between the device and the
    // point, none where a unilateral one would pull.
    for (int p = 0; p < n_probes_; ++p)
      {
        const ReducedProbe   &pr = probes_[p];
        const auto           &U  = probe_basis_[p];
        const Eigen::Vector3d u = U * x, u_dot = U * v1_;
        Eigen::Vector3d       f;
        for (int d = 0; d < 3; ++d)
          f(d) = pr.stiffness * (part_target_[p][d] - u(d)) + pr.damping * (pr.target_velocity[d] - u_dot(d));
        const bool active = !pr.unilateral || f(0) * pr.direction[0] + f(1) * pr.direction[1] + f(2) * pr.direction[2] > 0;
        if (!active)
          f.setZero();
        probe_trial_force_[p] = {f(0), f(1), f(2)};
        probe_active_[p]      = active;
        g_c.noalias() += U.transpose() * f;
      }
    if (C)
      contact_tangent(planes, *C);
    if (floating_ && options_.keep_angular_momentum)
      {
        // The projected forces' torque made the true one: a torque on the body as a whole, a
        // rigid rotation's load C w (C = U^T M (e_k x X~)), takes out of the internal force
        // the torque that its projection has (the objective law's full force has none) and
        // gives the planes' projected force the torque of their forces at the deformed
        // vertices, each at its own time level: A_af (g - C w) = (1 - af) (A_1 g_c1 - tau_1)
        // + af (A_0 g_c0 - tau_0), the step start's term kept from the carry, so the rigid
        // rows give A q'' = tau_c. The elastic rows are left as they are: a correction along A
        // itself would take stiffness out with it. With every mode, nothing changes (with U's
        // own rows: rounded ones hold e x (U q) to their rounding only). (The probes' forces,
        // in g_c here, would need their torque too: a floating body takes none.)
        angular_momentum_map(x);
        const Eigen::Vector3d leak = contact_torque_trial_ - momentum_map_.transpose() * g_c;
        contact_leak_trial_ = leak;
        angular_momentum_map(q_af_);
        const Eigen::Matrix3d B = momentum_map_.transpose() * rotation_loads_;
        const Eigen::Vector3d s = momentum_map_.transpose() * g_int_ + (1 - af) * leak + af * contact_leak_;
        g_int_.noalias() -= rotation_loads_ * B.partialPivLu().solve(s);
      }
    res += g_int_;
    res -= (1 - af) * (g_c + g_f_new_) + af * (g_c_ + g_f_);
    scale_ = std::max({scale_, g_int_.norm(), g_c.norm(), g_f_new_.norm()});
    return ok;
  }

  void
  ReducedNonlinearBody::contact_tangent(const ReducedPlane *planes, Matrix &C)
  {
    // The planes' penalty is linear in the depth, so their tangent depends only on which
    // vertices touch which plane, each one's stiffness and the plane's normal; a probe's
    // coupling only on its patch's rows U_p and its weight (1 - af) (k + b gamma / (beta h)),
    // zero where it is inactive. The matrix is kept while all of those stay (bit for bit what
    // it would be made again), and with it the factorization.
    const double coupling_rate = m_.gamma / (m_.beta * h_);
    for (int p = 0; p < n_probes_; ++p)
      probe_weight_[p] = probe_active_[p] ? (1 - m_.alpha_f) * (probes_[p].stiffness + probes_[p].damping * coupling_rate) : 0.0;
    bool same = options_.keep_factorization && contact_key_valid_ && n_contacts_ == key_contacts_ &&
                n_probes_ == key_probes_;
    for (size_t c = 0; same && c < n_contacts_; ++c)
      same = key_vertex_[c] == contact_vertex_[c] && key_weight_[c] == contact_weight_[c] &&
             key_normal_[c] == planes[contact_plane_[c]].normal;
    for (int p = 0; same && p < n_probes_; ++p)
      same = key_probe_weight_[p] == probe_weight_[p] && key_probe_basis_[p] == probe_basis_[p];
    if (same)
      return;
    C.setZero();
    for (size_t c = 0; c < n_contacts_; ++c)
      {
        const auto &nrm = planes[contact_plane_[c]].normal;
        Un_.noalias()   = surface_rows(contact_vertex_[c]).transpose() * Eigen::Vector3d(nrm[0], nrm[1], nrm[2]);
        C.selfadjointView<Eigen::Lower>().rankUpdate(Un_, contact_weight_[c]);
        key_vertex_[c] = contact_vertex_[c];
        key_weight_[c] = contact_weight_[c];
        key_normal_[c] = nrm;
      }
    for (int p = 0; p < n_probes_; ++p)
      {
        if (probe_weight_[p] != 0)
          C.selfadjointView<Eigen::Lower>().rankUpdate(probe_basis_[p].transpose(), probe_weight_[p]);
        key_probe_weight_[p] = probe_weight_[p];
        key_probe_basis_[p]  = probe_basis_[p];
      }
    key_contacts_      = n_contacts_;
    key_probes_        = n_probes_;
    contact_key_valid_ = true;
    ++tangent_version_;
  }

  bool
  ReducedNonlinearBody::step(const ReducedPlane *planes, const int n,
                             const ReducedVertexForce *forces, const int n_forces,
                             const ReducedProbe *probes, const int n_probes)
  {
    if (n < 0 || n > max_planes || (n > 0 && !planes) || n_forces < 0 || (n_forces > 0 && !forces) ||
        n_probes < 0 || n_probes > max_probes || (n_probes > 0 && !probes) || (floating_ && n_probes > 0))
      return false;
    for (int p = 0; p < n_probes; ++p)
      {
        const ReducedProbe &pr = probes[p];
        if (!(std::isfinite(pr.stiffness) && pr.stiffness > 0 && std::isfinite(pr.damping) && pr.damping >= 0) ||
            !patch_basis(pr.vertices.data(), pr.weights.data(), pr.n_patch, probe_basis_[p]))
          return false;
        for (int d = 0; d < 3; ++d)
          if (!std::isfinite(pr.target[d]) || !std::isfinite(pr.target_velocity[d]) || !std::isfinite(pr.direction[d]))
            return false;
        probes_[p] = pr;
      }
    if (!vertex_load(forces, n_forces, g_f_end_, frame_rotation_.transpose()))
      return false;
    n_probes_ = n_probes;
    stepped_  = true;
    g_f_end_ += body_force_; // a floating body's in its frame: start() and each carry set it
    // The state at the step's start, to go back to if Newton fails at tau.
    q0_ = q_, v0_ = v_, a0_ = a_, g_c0_ = g_c_, g_f0_ = g_f_, contact_leak0_ = contact_leak_;
    bool converged = false;
    for (unsigned parts = 1; parts <= max_parts && !converged; parts *= 2)
      {
        if (parts > 1)
          {
            q_ = q0_, v_ = v0_, a_ = a0_, g_c_ = g_c0_, g_f_ = g_f0_, contact_leak_ = contact_leak0_;
            ++cut_steps_;
          }
        converged = true;
        for (unsigned j = 1; j <= parts; ++j)
          {
            // The planes and forces where they are at this part's end: linear between the
            // latest step's and this one's (a plane new this step stands where it is given).
            const double s = double(j) / parts;
            for (int p = 0; p < n; ++p)
              {
                part_planes_[p] = planes[p];
                if (parts > 1 && p < last_n_)
                  for (int d = 0; d < 3; ++d)
                    {
                      part_planes_[p].point[d]  = last_planes_[p].point[d] + s * (planes[p].point[d] - last_planes_[p].point[d]);
                      part_planes_[p].normal[d] = last_planes_[p].normal[d] + s * (planes[p].normal[d] - last_planes_[p].normal[d]);
                    }
                const double norm = std::sqrt(part_planes_[p].normal[0] * part_planes_[p].normal[0] +
                                              part_planes_[p].normal[1] * part_planes_[p].normal[1] +
                                              part_planes_[p].normal[2] * part_planes_[p].normal[2]);
                for (int d = 0; d < 3; ++d)
                  part_planes_[p].normal[d] /= norm;
              }
            if (floating_)
              planes_to_body(part_planes_.data(), n);
            for (int p = 0; p < n_probes; ++p)
              for (int d = 0; d < 3; ++d)
                part_target_[p][d] = parts > 1 && last_target_known_[p]
                                       ? last_target_[p][d] + s * (probes[p].target[d] - last_target_[p][d])
                                       : probes[p].target[d];
            g_f_new_ = g_f0_ + s * (g_f_end_ - g_f0_);
            h_       = m_.time_step / parts;
            // At the last division every part is taken, converged or not (its best iterate).
            if (!solve(part_planes_.data(), n) && (converged = false, parts < max_parts))
              break;
          }
      }
    h_ = m_.time_step;
    if (!converged)
      ++failed_steps_;
    if (floating_)
      {
        sum_external_torque(forces, n_forces);
        for (int p = 0; p < n; ++p)
          {
            const Eigen::Vector3d f = frame_rotation_ * Eigen::Vector3d(plane_force_[p][0], plane_force_[p][1], plane_force_[p][2]);
            plane_force_[p] = {f(0), f(1), f(2)};
          }
        carry_into_new_frame(forces, n_forces);
      }
    if (options_.tangent_steps > 0) // after the carry: the state the next step starts from
      advance_staged_tangent();
    for (int p = 0; p < n; ++p)
      last_planes_[p] = planes[p];
    last_n_ = n;
    for (int p = 0; p < max_probes; ++p)
      {
        last_target_known_[p] = p < n_probes;
        if (p < n_probes)
          last_target_[p] = probes[p].target;
        else
          probe_force_[p] = {0, 0, 0};
      }
    return converged;
  }

  bool
  ReducedNonlinearBody::evaluate(const ReducedPlane *planes, const int n, const bool body)
  {
    if (body)
      {
        // Fresher than one in the making, which shares its work space.
        staging_ = tangent_wanted_ = stage_at_start_ = false;
        ++tangent_evaluations_;
        ++tangent_version_;
        body_tangent_h_ = h_;
      }
    return residual(x_, planes, n, residual_, body ? &body_tangent_ : nullptr, &contact_tangent_,
                    g_c_trial_, trial_force_, trial_vertices_);
  }

  bool
  ReducedNonlinearBody::solve(const ReducedPlane *planes, const int n)
  {
    // The body's tangent of an earlier step serves while it was made for this step length.
    const bool fresh = !options_.reuse_tangent || body_tangent_h_ != h_;
    part_start_rows();
    // Constant-velocity predictor, as the FEM's.
    x_ = q_ + h_ * v_ + (0.5 * h_ * h_) * a_;
    if (!evaluate(planes, n, fresh))
      {
        ++inverted_;
        x_ = q_;
        evaluate(planes, n, fresh);
      }
    // Converged when the residual is round-off of the forces in it, or the update is. A
    // residual that is not finite is never converged: the part fails and the step is cut.
    bool     tangent_at_x = fresh; // the body's tangent is x_'s own
    bool     blind_step_raised = false; // the last iterate: a full step past the line search, the residual up
    double   r_norm       = residual_.norm();
    double   best_norm    = r_norm;
    best_                 = x_;
    bool     converged    = false;
    unsigned it           = 0;
    constexpr unsigned max_iterations = 30;
    for (; it < max_iterations && std::isfinite(r_norm); ++it)
      {
        if (r_norm <= options_.tolerance * std::max(scale_, 1e-300) && std::isfinite(scale_))
          {
            converged = true;
            break;
          }
        // (A part of another length evaluates the body's tangent afresh, so its version moves.)
        if (!options_.keep_factorization || factorized_version_ != tangent_version_)
          {
            tangent_.triangularView<Eigen::Lower>() = body_tangent_ + contact_tangent_;
            solver_.compute(tangent_);
            ++factorizations_;
            factorized_h_       = h_;
            factorized_version_ = tangent_version_;
          }
        dq_ = solver_.solve(residual_);
        dq_ = -dq_;
        // A backtracking line search on the residual norm. Where it finds no decrease with a
        // kept tangent, the tangent is evaluated at x and the iteration done again. Where even
        // x's own tangent finds none (a vertex about to touch a plane: the tangent at x lacks
        // its penalty, and the full step overshoots into the plane), the full step is taken
        // all the same, the tangent there holding the contact, and Newton comes back from the
        // other side. But not twice running where the first raised the residual, nor where its
        // residual is not finite: that is Newton diverging, and the part fails.
        double alpha    = 1;
        bool   accepted = false, full_step_sound = false;
        for (int cut = 0; cut < 6; ++cut, alpha /= 2)
          {
            trial_ = x_ + alpha * dq_;
            const bool ok = residual(trial_, planes, n, r_trial_, nullptr, &contact_tangent_,
                                     g_c_trial_, trial_force_, trial_vertices_);
            if (!ok)
              ++inverted_;
            const double trial_norm = r_trial_.norm();
            if (cut == 0)
              full_step_sound = std::isfinite(trial_norm) && !blind_step_raised;
            if (ok && trial_norm < (1 - 1e-4 * alpha) * r_norm)
              {
                accepted = true;
                break;
              }
          }
        const double previous = r_norm;
        if (accepted)
          {
            // The accepted trial's residual and planes' tangent are the new iterate's.
            x_ = trial_;
            residual_.swap(r_trial_);
          }
        else if (!tangent_at_x)
          {
            evaluate(planes, n, true);
            tangent_at_x = true;
            continue;
          }
        else if (full_step_sound)
          {
            x_ += dq_;
            evaluate(planes, n, false);
          }
        else
          {
            evaluate(planes, n, false); // x_'s own planes' tangent and forces again
            break;
          }
        tangent_at_x      = false;
        blind_step_raised = !accepted && residual_.norm() > r_norm;
        r_norm            = residual_.norm();
        if (r_norm < best_norm)
          best_norm = r_norm, best_ = x_;
        if (accepted && alpha * dq_.norm() <= 1e-13 * std::max(x_.norm(), 1e-300))
          {
            converged = true;
            ++it;
            break;
          }
        // Newton's method evaluates the body's tangent at every iterate; a kept tangent is
        // evaluated again where the contraction was slow, at once or over the next steps; but
        // at once where the kept one hardly steers any more, and past half the iterations a
        // step may take, so that going on with it never costs a step its convergence (and the
        // step's cut into parts).
        if (!options_.reuse_tangent || r_norm > options_.tangent_refresh_ratio * previous)
          {
            if (options_.reuse_tangent && options_.tangent_steps > 0 && h_ == m_.time_step &&
                r_norm <= options_.tangent_at_once_ratio * previous && it + 1 < max_iterations / 2)
              tangent_wanted_ = true;
            else
              {
                evaluate(planes, n, true);
                tangent_at_x = true;
              }
          }
      }
    last_iterations_ = it;
    // The state at the part's end: residual() left a1_, v1_ and the planes' force at x_
    // unless the best iterate is an earlier one.
    if (!converged && best_ != x_)
      {
        x_ = best_;
        evaluate(planes, n, false);
      }
    plane_force_    = trial_force_;
    plane_vertices_ = trial_vertices_;
    probe_force_    = probe_trial_force_;
    q_   = x_;
    v_   = v1_;
    a_   = a1_;
    g_c_ = g_c_trial_;
    contact_leak_ = contact_leak_trial_;
    g_f_ = g_f_new_;
    return converged;
  }

  void
  ReducedNonlinearBody::surface_displacement(double *u) const
  {
    const size_t S = m_.surface_vertex.size();
    std::fill(u, u + 3 * S, 0.0);
    for (size_t k = 0; k < surface_index_.size(); ++k)
      {
        const Eigen::Vector3d &X  = surface_rest_[k];
        const auto             U  = surface_rows(k);
        const Eigen::Vector3d  us = floating_ ? Eigen::Vector3d(frame_origin_ + frame_rotation_ * (X - center0_ + U * q_) - X)
                                              : Eigen::Vector3d(U * q_);
        for (int d = 0; d < 3; ++d)
          u[3 * surface_index_[k] + d] = us(d);
      }
  }

  Eigen::Vector3d
  ReducedNonlinearBody::center_of_mass() const
  {
    if (m_.rigid_loads.size() != 6 * size_t(r_) || !(m_.mass > 0))
      return frame_origin_;
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> G(m_.rigid_loads.data(), r_, 6);
    return frame_origin_ + frame_rotation_ * (G.leftCols<3>().transpose() * q_ / m_.mass);
  }

  void
  ReducedNonlinearBody::sum_external_torque(const ReducedVertexForce *forces, const int n_forces)
  {
    // Arms from the centre of mass, in the step's frame: X~ + U_s q - (c - c0).
    const Eigen::Vector3d shift = translation_loads_.transpose() * q_ / m_.mass;
    Eigen::Vector3d       tau   = Eigen::Vector3d::Zero();
    for (size_t c = 0; c < n_contacts_; ++c)
      {
        const unsigned  s    = contact_vertex_[c];
        const auto     &free = m_.free_dof[surface_index_[s]];
        Eigen::Vector3d f    = contact_force_[c];
        for (int d = 0; d < 3; ++d)
          if (!free[d])
            f(d) = 0; // the support's, as plane_force leaves it out
        tau += (surface_rest_[s] - center0_ + surface_rows(s) * q_ - shift).cross(f);
      }
    const Eigen::Matrix3d Rt = frame_rotation_.transpose();
    for (int i = 0; i < n_forces; ++i)
      {
        const unsigned  v = forces[i].vertex; // checked by the step's vertex_load
        Eigen::Vector3d x = Eigen::Vector3d(m_.coordinates[v][0], m_.coordinates[v][1], m_.coordinates[v][2]) - center0_ - shift;
        Eigen::Vector3d f = Rt * Eigen::Vector3d(forces[i].force[0], forces[i].force[1], forces[i].force[2]);
        for (int d = 0; d < 3; ++d)
          {
            if (!m_.free_dof[v][d])
              f(d) = 0;
            x(d) += basis_row(m_.surface_vertex[v], d) * q_;
          }
        tau += x.cross(f);
      }
    torque_ = frame_rotation_ * tau;
  }

  Eigen::Vector3d
  ReducedNonlinearBody::angular_momentum() const
  {
    if (!floating_)
      return Eigen::Vector3d::Constant(NAN);
    // sum_ab eps_kab (X~ + U q)_a^T M_s (U q')_b about c0, less (c - c0) x p: A q' about the
    // centre of mass, turned into the world.
    angular_momentum_map(q_);
    return frame_rotation_ * (momentum_map_.transpose() * v_);
  }

  double
  ReducedNonlinearBody::strain_energy(const Vector &q) const
  {
    // Element by element from U's rows (not through the residual's work space: a const call
    // writes nothing).
    double            W = 0;
    elastic::Vector12 u_e, f_e;
    for (size_t k = 0; k < element_.size(); ++k)
      {
        double w_e = 0;
        for (int a = 0; a < 4; ++a)
          for (int d = 0; d < 3; ++d)
            u_e(3 * a + d) = vertex_basis_.row(3 * Eigen::Index(element_vertices_[k][a]) + d).dot(q);
        if (elastic::neo_hookean_force(element_[k], u_e, m_.mu, m_.lambda, f_e, nullptr, &w_e))
          W += weight_[k] * w_e;
      }
    return W;
  }

  double
  ReducedNonlinearBody::energy() const
  {
    return 0.5 * v_.squaredNorm() + strain_energy(q_);
  }
} // namespace irdm
