#pragma once
// The reduced nonlinear model's tangent U^T K U in single precision, in two products: K U by
// the body's 3 x 3 blocks (K in block CSR over the cubature's vertices, U's rows rounded to
// float), then the lower triangle of U^T (K U). The tangent only steers Newton (the residual
// is summed in double: surface_product.h), so float sums' rounding changes the convergence,
// not the root. Each product has a portable kernel (the build's own flags: SSE2 on x86-64)
// and an AVX2/FMA one; the dispatchers take the faster this CPU runs (decided once). The
// kernels are allocation-free and here so that a test can hold them to an exact sum.
#include <cstddef>

namespace irdm::detail
{
  /// A symmetric matrix of 3 x 3 blocks in block CSR: block row i holds the blocks
  /// row_start[i] .. row_start[i + 1] - 1, block s at block column column[s], its nine entries
  /// at blocks[9 s ..] column-major (Eigen::Matrix3d's layout).
  struct BlockRows
  {
    const double   *blocks;
    const unsigned *row_start;
    const unsigned *column;
    std::size_t     n_block_rows;
  };

  /// out = K rows: out[(3 i + a) M + m] = sum over row i's blocks s and b < 3 of
  /// B_s(a, b) rows[(3 column[s] + b) M + m], m < M; rows and out row-major, M wide; out has
  /// 3 n_block_rows rows. Products and sums in float (the blocks rounded to float).
  void
  block_rows_product_portable(const BlockRows &K, const float *rows, std::size_t M, float *out);
  void
  block_rows_product_avx2(const BlockRows &K, const float *rows, std::size_t M, float *out);
  void
  block_rows_product(const BlockRows &K, const float *rows, std::size_t M, float *out);

  /// lower[i M + j] += sum_k A[k M + i] B[k M + j] for j <= i < M, k < n_rows (A^T B's lower
  /// triangle, row-major M x M). Entries above the diagonal may be written too and are to be
  /// ignored. Products and sums in float.
  void
  lower_transposed_product_portable(const float *A, const float *B, std::size_t n_rows,
                                    std::size_t M, float *lower);
  void
  lower_transposed_product_avx2(const float *A, const float *B, std::size_t n_rows,
                                std::size_t M, float *lower);
  void
  lower_transposed_product(const float *A, const float *B, std::size_t n_rows, std::size_t M,
                           float *lower);
} // namespace irdm::detail
