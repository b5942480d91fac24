// Shift-invert block Lanczos for the lowest eigenpairs of K phi = w2 M phi (K, M symmetric,
// M positive definite), given only block maps: B -> (K - s M)^-1 B and V -> M V.
//
// Why a block method of our own: the sparse route's cost is the triangular solves with the
// Cholesky factor of K - s M, and a solve is bound by memory bandwidth (the factor is read
// twice per solve). A solve with 64 right-hand sides reads it as often as one with a single
// right-hand side, so a block Krylov method pays a seventh (cat_fine P2) to a tenth (cat_xfine
// P2) per vector of what SLEPc's single-vector Krylov-Schur paid (reports/scaling/
// sparse_route.md). The method is the
// shifted block Lanczos of Grimes, Lewis and Simon (SIAM J. Matrix Anal. Appl. 15, 1994), the
// eigensolver of structural codes, here with full reorthogonalization and no restart: the
// basis grows until the wanted Ritz pairs have converged.
//
// Plain C++ and Eigen (BLAS for the large products); no deal.II, no PETSc.
#pragma once

#include <Eigen/Dense>

#include <functional>

namespace irdm::fem
{
  /// A map applied to every column of a block (n x b -> n x b).
  using BlockMap = std::function<Eigen::MatrixXd(const Eigen::MatrixXd &)>;

  /// The wanted eigenpairs of S = (K - s M)^-1 M, which is symmetric in the M inner product:
  /// S x = theta x is K x = (s + 1 / theta) M x. The largest theta are the eigenvalues nearest
  /// the shift s from above (the lowest modes when s lies below them).
  struct LanczosPairs
  {
    Eigen::VectorXd theta;          ///< the wanted Ritz values, descending
    Eigen::MatrixXd vectors;        ///< their Ritz vectors x, M-orthonormal (n x wanted);
                                    ///< empty unless asked for (keep_ritz_vectors)
    /// S x / theta for each Ritz vector x: one step of inverse iteration ("purification"),
    /// which takes out what the random start block left of the modes far from the shift. It
    /// needs no solve: the Lanczos relation S Q = Q T + Q_{j+1} R_j E_j^T gives
    /// S x = theta x + Q_{j+1} R_j y_j. Not normalized.
    Eigen::MatrixXd purified;
    unsigned        block_solves = 0; ///< applications of (K - s M)^-1 to a block
    Eigen::Index    basis        = 0; ///< Krylov basis size at convergence
    double largest_estimate = 0; ///< largest |S x - theta x|_M / theta among the wanted
    double seconds          = 0; ///< wall time of the whole solve
    double seconds_solves   = 0; ///< of it, in shifted_solve
  };

  /// The `wanted` largest eigenpairs of S, each converged to |S x - theta x|_M <= tolerance
  /// theta. shifted_solve(B) = (K - s M)^-1 B, mass(V) = M V; n the dimension. Blocks of
  /// `block` columns; the basis grows to at most max_basis vectors (0: min(n, 8 wanted +
  /// 4 block)), beyond which it throws std::runtime_error. The start block is random with a
  /// fixed seed: the result is reproducible. The Ritz vectors themselves are kept only if
  /// keep_ritz_vectors (the purified ones are what a caller uses; each set is 8 n wanted
  /// bytes, 390 MB on cat_xfine P2, while the basis is still held).
  LanczosPairs
  block_lanczos(Eigen::Index n, Eigen::Index wanted, const BlockMap &shifted_solve,
                const BlockMap &mass, double tolerance, Eigen::Index block = 64,
                Eigen::Index max_basis = 0, bool keep_ritz_vectors = false);
} // namespace irdm::fem
