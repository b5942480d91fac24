// Products of tall dense blocks by BLAS (op(A) B, W -= A C), for the sparse modal route:
// Eigen's own GEMM is built for the baseline instruction set here, OpenBLAS uses the
// machine's widest vectors and both cores.
#pragma once

#include "blas.h"

#include <Eigen/Dense>

#include <stdexcept>
#include <string>
#include <vector>

namespace irdm::fem
{
  using ConstBlock = Eigen::Ref<const Eigen::MatrixXd>;

  // op(A) B by BLAS, op(A) = A or A^T.
  inline Eigen::MatrixXd
  product(const ConstBlock &A, const bool transpose_a, const ConstBlock &B)
  {
    const int       m = static_cast<int>(transpose_a ? A.cols() : A.rows());
    const int       k = static_cast<int>(transpose_a ? A.rows() : A.cols());
    const int       n = static_cast<int>(B.cols());
    Eigen::MatrixXd C = Eigen::MatrixXd::Zero(m, n);
    if (m == 0 || n == 0 || k == 0)
      return C;
    const int    lda = static_cast<int>(A.outerStride()), ldb = static_cast<int>(B.outerStride());
    const double one = 1, zero = 0;
    dgemm_(transpose_a ? "T" : "N", "N", &m, &n, &k, &one, A.data(), &lda, B.data(), &ldb,
           &zero, C.data(), &m);
    return C;
  }

  // W -= A C by BLAS.
  inline void
  subtract_product(const ConstBlock &A, const ConstBlock &C, Eigen::MatrixXd &W)
  {
    const int m = static_cast<int>(W.rows()), n = static_cast<int>(W.cols());
    const int k = static_cast<int>(A.cols());
    if (m == 0 || n == 0 || k == 0)
      return;
    const int    lda = static_cast<int>(A.outerStride()), ldb = static_cast<int>(C.outerStride());
    const double minus_one = -1, one = 1;
    dgemm_("N", "N", &m, &n, &k, &minus_one, A.data(), &lda, C.data(), &ldb, &one, W.data(),
           &m);
  }

  // The eigenvalues (ascending, into w) and eigenvectors (over A) of the symmetric A (its lower
  // triangle) by LAPACK's divide and conquer on OpenBLAS: Eigen's QR iteration, single-threaded
  // and built for the baseline instruction set, took 10 % of the eigensolver on cat_fine P2
  // (the Ritz problems) and minutes for the residual modes' Gram and stiffness matrices of
  // thousands of vectors.
  inline void
  symmetric_eigen(Eigen::MatrixXd &A, Eigen::VectorXd &w)
  {
    const int n = static_cast<int>(A.rows());
    w.resize(n);
    if (n == 0)
      return;
    int    info = 0, lwork = -1, liwork = -1, iwork_size = 0;
    double work_size = 0;
    dsyevd_("V", "L", &n, A.data(), &n, w.data(), &work_size, &lwork, &iwork_size, &liwork,
            &info);
    lwork  = static_cast<int>(work_size);
    liwork = iwork_size;
    std::vector<double> work(static_cast<size_t>(lwork));
    std::vector<int>    iwork(static_cast<size_t>(liwork));
    dsyevd_("V", "L", &n, A.data(), &n, w.data(), work.data(), &lwork, iwork.data(), &liwork,
            &info);
    if (info != 0)
      throw std::runtime_error("dsyevd failed (info " + std::to_string(info) + ")");
  }
} // namespace irdm::fem
