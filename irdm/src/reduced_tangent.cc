// The reduced nonlinear model's tangent (irdm/reduced_nonlinear.h): the cubature's stiffness
// by vertex pair and U^T (K U), made at once inside a step or a piece a step over several
// (ReducedBodyOptions::tangent_steps). Either way it is the same sum: the elements' blocks
// first (every block row needs all of them), then K U and U^T (K U) by ranges of block rows,
// whose shares of U^T (K U) add up.
#include <irdm/reduced_nonlinear.h>

#include "tangent_product.h"

#include <algorithm>

namespace irdm
{
  namespace
  {
    // An element's 12 values from the per-vertex ones, by its four vertices.
    void
    gather(const Eigen::VectorXd &per_vertex, const std::array<unsigned, 4> &vertices, elastic::Vector12 &x)
    {
      for (int a = 0; a < 4; ++a)
        x.segment<3>(3 * a) = per_vertex.segment<3>(3 * Eigen::Index(vertices[a]));
    }
  } // namespace

  void
  ReducedNonlinearBody::element_stiffness(const Vector &u, const Vector &v, const double af, const double c_c,
                                          const size_t e0, const size_t e1)
  {
    const bool damped = m_.rayleigh_beta != 0;
    if (e0 == 0)
      for (auto &B : stiffness_blocks_)
        B.setZero();
    elastic::Vector12 u_e, v_e, f_e;
    elastic::Matrix12 K_e, D_e;
    for (size_t k = e0; k < std::min(e1, element_.size()); ++k)
      {
        const auto &l = element_vertices_[k];
        const auto &t = element_[k];
        gather(u, l, u_e);
        if (!elastic::neo_hookean_force(t, u_e, m_.mu, m_.lambda, f_e, &K_e))
          continue;
        if (damped)
          {
            gather(v, l, v_e);
            elastic::objective_damping_force(t, u_e, v_e, m_.mu, m_.lambda, f_e, &D_e);
            K_e = (1 - af) * K_e + m_.rayleigh_beta * c_c * D_e;
          }
        else
          K_e *= 1 - af;
        for (int a = 0; a < 4; ++a)
          for (int b = 0; b < 4; ++b)
            stiffness_blocks_[element_blocks_[k][4 * a + b]] += weight_[k] * K_e.block<3, 3>(3 * a, 3 * b);
      }
  }

  void
  ReducedNonlinearBody::begin_tangent_sum()
  {
    if (options_.single_precision_rows)
      tangent_rows_.setZero();
  }

  void
  ReducedNonlinearBody::end_tangent_sum(Matrix &T)
  {
    if (options_.single_precision_rows)
      T.triangularView<Eigen::Lower>() += tangent_rows_.cast<double>();
  }

  void
  ReducedNonlinearBody::tangent_rows(const size_t i0, const size_t i1, Matrix &T)
  {
    // K U by block rows, then U^T (K U), symmetric: the lower triangle alone. Where the rows
    // are rounded to float, both products are formed in float arithmetic by kernels of their
    // own (tangent_product.h): the tangent only steers Newton and is kept over many
    // iterations, so its float sums' rounding changes the convergence, not the root. In
    // double, K U a vertex's rows at a time and U^T (K U) in slices of slice_ rows.
    if (i1 <= i0)
      return;
    const auto first = 3 * Eigen::Index(i0), n_rows = 3 * Eigen::Index(i1 - i0);
    if (options_.single_precision_rows)
      {
        static_assert(sizeof(Eigen::Matrix3d) == 9 * sizeof(double), "blocks read as an array");
        const detail::BlockRows K{reinterpret_cast<const double *>(stiffness_blocks_.data()), block_row_start_.data() + i0,
                                  block_column_.data(), i1 - i0};
        float *KU = KU_rows_.data() + first * r_;
        detail::block_rows_product(K, vertex_rows_.data(), r_, KU);
        detail::lower_transposed_product(vertex_rows_.data() + first * r_, KU, std::size_t(n_rows), r_,
                                         tangent_rows_.data());
        return;
      }
    for (size_t i = i0; i < i1; ++i)
      {
        KU_row_.setZero();
        for (unsigned s = block_row_start_[i]; s < block_row_start_[i + 1]; ++s)
          KU_row_.noalias() += stiffness_blocks_[s] * vertex_basis_.middleRows<3>(3 * Eigen::Index(block_column_[s]));
        KU_.middleRows<3>(3 * Eigen::Index(i)) = KU_row_;
      }
    for (Eigen::Index c = first; c < first + n_rows; c += slice_)
      {
        const Eigen::Index n = std::min(slice_, first + n_rows - c);
        T.triangularView<Eigen::Lower>() += vertex_basis_.middleRows(c, n).transpose() * KU_.middleRows(c, n);
      }
  }

  void
  ReducedNonlinearBody::stage_tangent()
  {
    // The tangent this step would make at its iterate x = q: the alpha level's displacement
    // U q and velocity U w, as part_start_rows() has just made them at the model's step.
    staged_u_ = vertex_q_, staged_v_ = vertex_w_;
    staging_      = true;
    staged_piece_ = 0;
  }

  bool
  ReducedNonlinearBody::tangent_piece(const unsigned pieces)
  {
    // The elements' stiffness in the first quarter of the pieces (at least one), then U^T
    // (K U) over the block rows in the rest (one piece: all of it). A quarter, not a share by
    // count: the elements' law kernels run one element at a time, the row products near the
    // core's peak, so by time the elements are a good part of the whole.
    const double   h = m_.time_step, am = m_.alpha_m, af = m_.alpha_f, b = m_.beta, g = m_.gamma;
    const double   c_m = (1 - am) / (b * h * h), c_c = (1 - af) * g / (b * h);
    const size_t   block_rows = block_row_start_.size() - 1, elements = element_.size();
    const unsigned element_pieces = std::max(1u, pieces / 4);
    const unsigned ranges         = pieces > element_pieces ? pieces - element_pieces : 1;
    const unsigned p              = staged_piece_++;
    if (p < element_pieces)
      {
        if (p == 0)
          {
            staged_tangent_.setZero();
            staged_tangent_.diagonal().setConstant(c_m + c_c * m_.rayleigh_alpha);
            begin_tangent_sum();
          }
        element_stiffness(staged_u_, staged_v_, af, c_c, elements * p / element_pieces,
                          elements * (p + 1) / element_pieces);
        if (pieces > element_pieces)
          return false;
      }
    const unsigned j = pieces > element_pieces ? p - element_pieces : 0;
    tangent_rows(block_rows * j / ranges, block_rows * (j + 1) / ranges, staged_tangent_);
    if (j + 1 < ranges)
      return false;
    end_tangent_sum(staged_tangent_);
    body_tangent_.swap(staged_tangent_);
    body_tangent_h_ = h;
    ++tangent_version_;
    staging_ = false;
    return true;
  }

  void
  ReducedNonlinearBody::advance_staged_tangent()
  {
    // A request while one is in the making is dropped: that one comes first.
    if (staging_)
      {
        if (tangent_piece(options_.tangent_steps))
          ++staged_tangents_;
      }
    else if (tangent_wanted_ && body_tangent_h_ == m_.time_step)
      stage_at_start_ = true; // at the next step's start, where U q and U w are made anyway
    tangent_wanted_ = false;
  }

  void
  ReducedNonlinearBody::prepare_tangent()
  {
    // As a step makes it at its iterate x = q (the first step's predictor, at rest).
    h_ = m_.time_step;
    part_start_rows();
    x_ = q_;
    evaluate(nullptr, 0, true);
    stage_at_start_ = false;
  }
} // namespace irdm
