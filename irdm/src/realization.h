#pragma once
// Internal to irdm/src: what every state-space realization shares (ERA, balanced truncation):
// the leading singular triplets of a matrix, and the runtime's block-diagonal form of A.
#include <irdm/state_space_model.h>

#include <Eigen/Dense>

namespace irdm::realization
{
  using Mat = Eigen::MatrixXd;
  using Vec = Eigen::VectorXd;

  struct Svd
  {
    Mat U, V;
    Vec sigma;
  };

  /// The leading k singular triplets of a: exact (divide and conquer) when k is within 30 of
  /// its smaller side, else a randomized range finder with two power steps and a fixed seed
  /// (Halko, Martinsson and Tropp 2011), so that the same data give the same model.
  Svd
  leading_svd(const Mat &a, unsigned k);

  /// Sets out's poles, b and c from (A, B, C) in real block-diagonal form: T^-1 A T =
  /// diag(real poles, [a b; -b a] per pair), T's columns A's eigenvectors; poles beyond
  /// radius pulled onto it (counted). out.n_inputs must be set. InputError when A has no
  /// basis of eigenvectors.
  void
  set_block_diagonal(StateSpaceModel &out, const Mat &A, const Mat &B, const Mat &C, double radius);

  /// The feed-through D = H[0] (n_inputs x n_outputs, row-major) from the model's H.
  inline void
  set_feedthrough_from_h(StateSpaceModel &out, const ImpulseResponseModel &m)
  {
    out.d.resize(static_cast<size_t>(m.n_inputs) * m.n_outputs);
    for (unsigned k = 0; k < m.n_inputs; ++k)
      for (unsigned j = 0; j < m.n_outputs; ++j)
        out.d[static_cast<size_t>(k) * m.n_outputs + j] = m.h(k, 0, j);
  }
} // namespace irdm::realization
