#pragma once
// The best rigid fit of a deformed point set to its rest shape (seed 001, section 4.1: a free
// body's response is split into the rigid position and orientation that best fit the original
// shape to the deformed one, least squares over corresponding nodes, and the rest).
// Uniform weights: every point counts the same. The rotation is Kabsch's (Kabsch, Acta Cryst.
// A32, 922, 1976): R = V diag(1, 1, det(V U^T)) U^T from the SVD U S V^T of
// sum_i (X_i - X0)(x_i - x0)^T, X0 and x0 the two centroids; it is exact for any rotation
// angle. Shared by the virtual-DOF precompute (reference_fem) and the free-body validation, so
// that both split a motion the same way.
#include <Eigen/Dense>
#include <Eigen/SVD>

#include <utility>
#include <vector>

namespace irdm
{
  struct RigidFit
  {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity(); // rest -> deformed
    Eigen::Vector3d rest_centroid = Eigen::Vector3d::Zero(), centroid = Eigen::Vector3d::Zero();
    // R^T (x_i - x0) - (X_i - X0): what is left of each point's motion in the fitted frame.
    std::vector<Eigen::Vector3d> deformation;
  };

  /// Kabsch's rotation from the cross-covariance H = sum_i w_i (X_i - X0)(x_i - x0)^T (any
  /// weights w_i >= 0): the rotation R (rest -> deformed) that minimizes
  /// sum_i w_i |R (X_i - X0) - (x_i - x0)|^2.
  inline Eigen::Matrix3d
  kabsch_rotation(const Eigen::Matrix3d &H)
  {
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2)           = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
    return svd.matrixV() * D * svd.matrixU().transpose();
  }

  /// With `centers` (rest, deformed) given, the translation is theirs instead of the
  /// centroids' (a free body's centre of mass, known from the FEM: mass weights for the
  /// translation) and the rotation is the best about them.
  inline RigidFit
  best_rigid_fit(const std::vector<Eigen::Vector3d> &rest, const std::vector<Eigen::Vector3d> &x,
                 const std::pair<Eigen::Vector3d, Eigen::Vector3d> *centers = nullptr)
  {
    RigidFit f;
    const size_t n = x.size();
    if (n == 0 || rest.size() != n)
      return f;
    if (centers)
      f.rest_centroid = centers->first, f.centroid = centers->second;
    else
      for (size_t i = 0; i < n; ++i)
        f.centroid += x[i] / n, f.rest_centroid += rest[i] / n;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < n; ++i)
      H += (rest[i] - f.rest_centroid) * (x[i] - f.centroid).transpose();
    f.rotation = kabsch_rotation(H);
    f.deformation.resize(n);
    for (size_t i = 0; i < n; ++i)
      f.deformation[i] = f.rotation.transpose() * (x[i] - f.centroid) - (rest[i] - f.rest_centroid);
    return f;
  }
} // namespace irdm
