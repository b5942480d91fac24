// The shift-invert block Lanczos eigensolver of the sparse route, on small dense generalized
// problems whose every eigenpair LAPACK/Eigen gives: eigenvalues, M-orthonormality and
// residuals; the purified vectors (S x / theta from the Lanczos relation) against an explicit
// solve; a multiple eigenvalue (a free body's six rigid modes share theta = 1 / eps); the
// whole space.
#include <reference_fem/block_lanczos.h>

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>

namespace fem = irdm::fem;

namespace
{
  // A chain of n masses and springs with varied stiffness (a 1D bar, consistent mass):
  // K and M tridiagonal and positive definite (one end fixed), eigenvalues spread over about
  // 4 n^2 / pi^2 in ratio, like a bar's.
  struct Bar
  {
    Eigen::MatrixXd K, M;
  };
  Bar
  bar(const Eigen::Index n)
  {
    Bar b{Eigen::MatrixXd::Zero(n, n), Eigen::MatrixXd::Zero(n, n)};
    for (Eigen::Index e = 0; e < n; ++e) // element e joins node e - 1 (fixed if -1) and e
      {
        const double k = 1.0 + 0.5 * std::sin(0.37 * static_cast<double>(e)), m = 1.0 / 6.0;
        b.K(e, e) += k;
        b.M(e, e) += 2 * m;
        if (e > 0)
          {
            b.K(e - 1, e - 1) += k;
            b.K(e - 1, e) -= k;
            b.K(e, e - 1) -= k;
            b.M(e - 1, e - 1) += 2 * m;
            b.M(e - 1, e) += m;
            b.M(e, e - 1) += m;
          }
      }
    return b;
  }

  // Runs block_lanczos at shift s and checks the wanted pairs against the exact eigenvalues
  // w2 (ascending); errors relative to the largest wanted eigenvalue (a rigid mode's is 0).
  void
  expect_lowest_pairs(const Eigen::MatrixXd &K, const Eigen::MatrixXd &M, const double shift,
                      const Eigen::VectorXd &exact, const Eigen::Index wanted,
                      const Eigen::Index block)
  {
    const Eigen::Index                 n = K.rows();
    const Eigen::LDLT<Eigen::MatrixXd> shifted(K - shift * M);
    const double                       scale = exact(wanted - 1);
    const fem::LanczosPairs pairs = fem::block_lanczos(
      n, wanted, [&](const Eigen::MatrixXd &B) { return Eigen::MatrixXd(shifted.solve(B)); },
      [&](const Eigen::MatrixXd &V) { return Eigen::MatrixXd(M * V); }, 1e-10, block, 0, true);
    ASSERT_EQ(pairs.theta.size(), wanted);
    ASSERT_EQ(pairs.vectors.cols(), wanted);
    ASSERT_EQ(pairs.purified.cols(), wanted);
    double worst_value = 0, worst_residual = 0, worst_purified = 0;
    for (Eigen::Index i = 0; i < wanted; ++i)
      {
        const double w2 = shift + 1 / pairs.theta(i);
        worst_value     = std::max(worst_value, std::abs(w2 - exact(i)) / scale);
        const Eigen::VectorXd x = pairs.vectors.col(i);
        worst_residual =
          std::max(worst_residual, (K * x - w2 * M * x).norm() / (scale * (M * x).norm()));
        // S x / theta by a solve, against the one read off the Lanczos relation.
        const Eigen::VectorXd solved = shifted.solve(M * x) / pairs.theta(i);
        worst_purified =
          std::max(worst_purified, (pairs.purified.col(i) - solved).norm() / solved.norm());
      }
    const Eigen::MatrixXd gram = pairs.vectors.transpose() * M * pairs.vectors;
    const double          orthonormality =
      (gram - Eigen::MatrixXd::Identity(wanted, wanted)).cwiseAbs().maxCoeff();
    std::printf("n %ld, %ld wanted, block %ld: %u block solves, basis %ld; eigenvalues %.1e, "
                "residual %.1e, M-orthonormality %.1e; purified against a solve %.1e\n",
                static_cast<long>(n), static_cast<long>(wanted), static_cast<long>(block),
                pairs.block_solves, static_cast<long>(pairs.basis), worst_value, worst_residual,
                orthonormality, worst_purified);
    EXPECT_LT(worst_value, 1e-9);
    EXPECT_LT(worst_purified, 1e-10);
    EXPECT_LT(worst_residual, 1e-8);
    EXPECT_LT(orthonormality, 1e-12);
    EXPECT_LE(pairs.largest_estimate, 1e-10);
  }
} // namespace

TEST(BlockLanczos, LowestPairsOfABarEqualTheDenseSolutionForEveryBlockSize)
{
  const Bar                                                       b = bar(400);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> dense(b.K, b.M);
  for (const Eigen::Index block : {1, 4, 16, 64})
    expect_lowest_pairs(b.K, b.M, 0.0, dense.eigenvalues(), 30, block);
}

TEST(BlockLanczos, FindsEveryCopyOfAnEigenvalueOfMultiplicityUpToTheBlockSize)
{
  // Six zero eigenvalues (the bar's lowest six replaced by 0, as a free body's rigid modes),
  // found at the shift -1e-6 as theta = 1e6 six times over, then the elastic ones above.
  const Bar                                                       b = bar(300);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> dense(b.K, b.M);
  Eigen::VectorXd                                                 w2 = dense.eigenvalues();
  w2.head(6).setZero();
  const Eigen::MatrixXd Phi = dense.eigenvectors(); // M-orthonormal: K = M Phi W2 Phi^T M
  const Eigen::MatrixXd K   = b.M * Phi * w2.asDiagonal() * Phi.transpose() * b.M;
  for (const Eigen::Index block : {6, 8})
    expect_lowest_pairs(0.5 * (K + K.transpose()), b.M, -1e-6, w2, 20, block);
}

TEST(BlockLanczos, TheWholeSpaceIsExact)
{
  const Bar                                                       b = bar(50);
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> dense(b.K, b.M);
  expect_lowest_pairs(b.K, b.M, 0.0, dense.eigenvalues(), 49, 16);
  EXPECT_THROW(fem::block_lanczos(
                 50, 0, [](const Eigen::MatrixXd &B) { return B; },
                 [](const Eigen::MatrixXd &V) { return V; }, 1e-10),
               std::invalid_argument);
}
