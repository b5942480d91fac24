// Shift-invert block Lanczos with full reorthogonalization (see block_lanczos.h for why).
//
// With S = (K - s M)^-1 M and an M-orthonormal basis Q = [Q_0 Q_1 ... Q_j] of the block
// Krylov space of a random start block, S Q_j = Q C_j + Q_{j+1} R_j: C_j = Q^T M S Q_j are the
// projections taken off (classical Gram-Schmidt twice, "twice is enough", Kahan/Parlett: first
// against the last two blocks, where C_j is nonzero but for round-off, then against the whole
// basis) and R_j the new block's coupling. T = Q^T M S Q collects them; it is symmetric because S is
// M-symmetric, and its eigenpairs (theta, y) give the Ritz pairs (theta, Q y) with residual
// |S Q y - theta Q y|_M = |R_j y_j| (y_j: y's rows of the last block), the usual Lanczos
// estimate, which decides convergence without touching the long vectors.
#include <reference_fem/block_lanczos.h>

#include "blas.h"
#include "dense_products.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace irdm::fem
{
  namespace
  {
    // The eigenvalues (ascending) and eigenvectors of the Gram matrix V^T M V.
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>
    gram_eigen(const Eigen::MatrixXd &V, const Eigen::MatrixXd &MV)
    {
      Eigen::MatrixXd G = product(V, true, MV);
      return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (G + G.transpose()));
    }

    // The next block a step makes: M-orthonormal columns V (and M V), with the step's W =
    // Q C + V R; C collects the projections on the basis taken on the way.
    struct Next
    {
      Eigen::MatrixXd V, MV, R, C;
    };

    // V <- V U diag(scale)^-1 and R <- diag(scale) U^T R (so V R is unchanged), for the
    // columns of U.
    void
    rotate(Next &o, const Eigen::MatrixXd &U, const Eigen::VectorXd &scale, const bool with_mass)
    {
      const Eigen::MatrixXd U_scaled = U * scale.cwiseInverse().asDiagonal();
      o.V                            = product(o.V, false, U_scaled);
      if (with_mass)
        o.MV = product(o.MV, false, U_scaled);
      o.R = (scale.asDiagonal() * U.transpose() * o.R).eval();
    }

    // The Krylov basis: M-orthonormal columns Q (and M Q), m of them so far, and
    // T = Q^T M S Q as the steps fill it.
    class KrylovBasis
    {
    public:
      KrylovBasis(const Eigen::Index n, const Eigen::Index max_basis, const BlockMap &mass)
        : Q(n, max_basis)
        , MQ(n, max_basis)
        , T(Eigen::MatrixXd::Zero(max_basis, max_basis))
        , n_(n)
        , mass_(mass)
      {}

      Eigen::MatrixXd Q, MQ, T;
      Eigen::Index    m = 0;

      ConstBlock
      basis() const
      {
        return ConstBlock(Q.leftCols(m));
      }

      // W less its M-orthogonal projection on the basis columns [from, m); returns their
      // Q^T M W.
      Eigen::MatrixXd
      project(Eigen::MatrixXd &W, const Eigen::Index from = 0) const
      {
        const Eigen::MatrixXd C = product(MQ.middleCols(from, m - from), true, W);
        subtract_product(Q.middleCols(from, m - from), C, W);
        return C;
      }

      // The next block from W (projected off the basis once): an M-orthonormal V,
      // M-orthogonal to the basis, with W = Q C + V R. This is block classical Gram-Schmidt
      // twice (BCGS2: the second projection is "twice is enough", Kahan and Parlett), with
      // each block orthonormalized by its Gram matrix's eigenvectors:
      // - round 1 in the Euclidean inner product (no product with M). A Gram matrix squares
      //   W's condition number, so W's small directions come out neither normalized nor
      //   orthogonal to the basis; nothing is dropped (scales below `floor` are taken as
      //   floor);
      // - round 2 projects again, drops the directions the projection took (they lay in the
      //   basis, which then holds an invariant subspace) and M-orthonormalizes what is left;
      // - round 3 repeats round 2 if its M-Gram matrix was far from the identity.
      // M V is computed afresh after the projection: updating it by M Q c would keep only the
      // digits of the larger M W before it.
      Next
      next_block(Eigen::MatrixXd W, const double floor) const
      {
        const Eigen::Index b = W.cols();
        Next               out{std::move(W), Eigen::MatrixXd(), Eigen::MatrixXd::Identity(b, b),
                               Eigen::MatrixXd::Zero(m, b)};
        {
          const auto   gram = gram_eigen(out.V, out.V);
          const auto   d    = gram.eigenvalues().reverse().eval();
          Eigen::Index kept = 0;
          while (kept < d.size() && d(kept) > 0)
            ++kept;
          rotate(out, gram.eigenvectors().rowwise().reverse().leftCols(kept),
                 d.head(kept).cwiseSqrt().cwiseMax(floor), false);
        }
        for (int round = 2; round <= 3 && out.V.cols() > 0; ++round)
          {
            out.C += project(out.V) * out.R;
            // What the projection left of the (Euclidean-orthonormal) columns.
            const auto   left = gram_eigen(out.V, out.V);
            const auto   e    = left.eigenvalues().reverse().eval();
            Eigen::Index kept = 0;
            while (kept < e.size() && e(kept) > 1e-6)
              ++kept;
            if (kept < e.size())
              rotate(out, left.eigenvectors().rowwise().reverse().leftCols(kept),
                     e.head(kept).cwiseSqrt(), false);
            if (kept == 0)
              break;
            out.MV          = mass_(out.V);
            const auto gram = gram_eigen(out.V, out.MV);
            const auto d    = gram.eigenvalues().reverse().eval();
            if (!(d(d.size() - 1) > 0))
              throw std::runtime_error("block Lanczos: the mass matrix is not positive definite");
            rotate(out, gram.eigenvectors().rowwise().reverse(), d.cwiseSqrt(), true);
            if (d(0) < 1e4 * d(d.size() - 1))
              break; // orthonormal to round-off times the condition number
          }
        return out;
      }

      void
      append(const Next &o)
      {
        Q.middleCols(m, o.V.cols())  = o.V;
        MQ.middleCols(m, o.V.cols()) = o.MV;
        m += o.V.cols();
      }

      // Up to `count` random directions M-orthogonal to the basis, appended (fewer if the
      // basis fills the space). They start the Krylov space, and they refill a block that
      // deflated, so that an eigenvalue of multiplicity above the block size is still found.
      void
      append_random(const Eigen::Index count)
      {
        Eigen::MatrixXd Z(n_, count);
        for (Eigen::Index j = 0; j < count; ++j)
          for (Eigen::Index i = 0; i < n_; ++i)
            Z(i, j) = normal_(random_);
        project(Z);
        append(next_block(std::move(Z), 0.0));
      }

    private:
      Eigen::Index                     n_;
      const BlockMap                  &mass_;
      std::mt19937_64                  random_{20261125};
      std::normal_distribution<double> normal_;
    };

    // The wanted Ritz pairs of the basis's first m_old columns (T's eigenpairs, largest
    // first), and the largest residual estimate |R y_j| / |theta| among them, y_j the rows of
    // the current block [start, start + b) and R the next block's coupling.
    struct Ritz
    {
      Eigen::VectorXd theta;
      Eigen::MatrixXd Y;
      double          worst = 0;
    };
    Ritz
    ritz_pairs(const Eigen::MatrixXd &T, const Eigen::Index m_old, const Eigen::Index wanted,
               const Eigen::MatrixXd &R, const Eigen::Index start, const Eigen::Index b)
    {
      Eigen::MatrixXd Tq = T.topLeftCorner(m_old, m_old);
      Tq                 = 0.5 * (Tq + Tq.transpose()).eval();
      Eigen::VectorXd all_theta;
      symmetric_eigen(Tq, all_theta);
      Ritz r;
      r.Y     = Tq.rightCols(wanted).rowwise().reverse();
      r.theta = all_theta.tail(wanted).reverse();
      for (Eigen::Index i = 0; i < wanted; ++i)
        {
          const double estimate = R.cols() > 0 ? (R * r.Y.col(i).segment(start, b)).norm() : 0.0;
          r.worst               = std::max(r.worst, estimate / std::abs(r.theta(i)));
        }
      return r;
    }
  } // namespace

  LanczosPairs
  block_lanczos(const Eigen::Index n, const Eigen::Index wanted, const BlockMap &shifted_solve,
                const BlockMap &mass, const double tolerance, const Eigen::Index block,
                Eigen::Index max_basis, const bool keep_ritz_vectors)
  {
    if (n < 1 || wanted < 1 || wanted > n || block < 1 || !(tolerance > 0))
      throw std::invalid_argument("block_lanczos: needs 1 <= wanted <= n, block >= 1 and a "
                                  "positive tolerance");
    if (max_basis == 0)
      max_basis = 8 * wanted + 4 * block;
    max_basis = std::min(max_basis, n);
    if (max_basis < wanted)
      throw std::invalid_argument("block_lanczos: the basis limit is below the pairs wanted");

    KrylovBasis     K(n, max_basis, mass);
    using Clock          = std::chrono::steady_clock;
    const auto   started = Clock::now();
    const auto   since   = [](const Clock::time_point t) {
      return std::chrono::duration<double>(Clock::now() - t).count();
    };
    K.append_random(std::min(block, max_basis));
    LanczosPairs out;
    double       theta_scale = 0; // the largest |T| of a diagonal block: the scale of S
    Eigen::Index start       = 0; // the current block: columns [start, m)
    Eigen::Index previous    = 0; // the block before it: columns [previous, start)
    while (true)
      {
        const Eigen::Index b = K.m - start, m_old = K.m;
        const auto         solve_started = Clock::now();
        Eigen::MatrixXd    W = shifted_solve(K.MQ.middleCols(start, b)); // S Q_j
        out.seconds_solves += since(solve_started);
        ++out.block_solves;
        // The first projection against the last two blocks only: S is M-symmetric, so
        // Q_i^T M S Q_j = (S Q_i)^T M Q_j vanishes for i < j - 1 (S Q_i lies in the basis up
        // to Q_{i+1}), and T is block tridiagonal but for round-off. next_block's projection
        // against the whole basis then takes out that round-off (the second pass of "twice
        // is enough"), and its coefficients join T. One pass over the basis per block
        // instead of two.
        Eigen::MatrixXd C              = Eigen::MatrixXd::Zero(m_old, b);
        C.bottomRows(m_old - previous) = K.project(W, previous);
        theta_scale                    = std::max(theta_scale, C.bottomRows(b).norm());
        // The next block, W = Q_{j+1} R (scales below round-off of S's are taken as that).
        const Next next = K.next_block(std::move(W), 1e-15 * theta_scale);
        C += next.C;
        K.T.block(0, start, m_old, b) = C;
        if (m_old >= wanted)
          {
            const Ritz ritz = ritz_pairs(K.T, m_old, wanted, next.R, start, b);
            if (ritz.worst <= tolerance)
              {
                out.theta = ritz.theta;
                // Formed in place: one n x wanted matrix beside the basis, not three.
                out.purified = product(K.basis(), false, ritz.Y);
                if (keep_ritz_vectors)
                  out.vectors = out.purified;
                if (next.R.cols() > 0)
                  subtract_product(next.V,
                                   -(next.R * ritz.Y.middleRows(start, b)) *
                                     ritz.theta.cwiseInverse().asDiagonal(),
                                   out.purified);
                out.basis            = m_old;
                out.largest_estimate = ritz.worst;
                out.seconds          = since(started);
                return out;
              }
            if (m_old + next.V.cols() > max_basis || (next.V.cols() == 0 && m_old == n))
              throw std::runtime_error(
                "block Lanczos: " + std::to_string(wanted) + " eigenpairs not converged in a "
                "basis of " + std::to_string(m_old) + " vectors (largest estimate " +
                std::to_string(ritz.worst) + " of theta, tolerance " + std::to_string(tolerance) +
                ")");
          }
        else if (m_old + next.V.cols() > max_basis)
          throw std::runtime_error("block Lanczos: the basis limit is reached before the "
                                   "wanted pairs could converge");
        K.append(next);
        K.T.block(m_old, start, next.R.rows(), b) = next.R;
        previous = start;
        start    = m_old;
        if (K.m - start < block && K.m < max_basis)
          K.append_random(std::min(block - (K.m - start), max_basis - K.m));
      }
  }
} // namespace irdm::fem
