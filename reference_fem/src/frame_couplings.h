#pragma once
// Internal: the free body's frame couplings of its elastic modes, the same for the dense and the
// sparse modal route (docs/free-body.md; /modes/centrifugal_load and /modes/inertial_coupling in
// docs/model-format.md). With M = M_s (x) I_3 the consistent mass (the three components of a
// node share one scalar mass matrix M_s):
//   centrifugal load of mode i, e = 3a + c:  Phi_i^T M W_e, W_e the linear field u_a = x_c - c_c
//                                             (c the centre of mass);
//   inertial coupling J_ab = Phi_a^T M_s Phi_b, Phi_a the a-components of the modes at the
//                                             nodes; (M_s Phi_b) is the b-rows of M Phi.
// No deal.II here: the routes pass their own vectors.
#include <reference_fem/scene.h>

#include <Eigen/Dense>

#include <array>
#include <map>
#include <stdexcept>
#include <vector>

namespace irdm::fem::frame_couplings
{
  /// The free DoFs grouped by node: (x, y, z) free indices of each support point, from each free
  /// DoF's offset from the centre and axis. Every node of a free body has three free DoFs.
  inline std::vector<std::array<int, 3>>
  node_triples(const std::vector<Vec3> &offset, const std::vector<unsigned char> &axis)
  {
    std::map<Vec3, std::array<int, 3>> node_of_point;
    for (size_t r = 0; r < offset.size(); ++r)
      node_of_point.try_emplace(offset[r], std::array<int, 3>{-1, -1, -1})
        .first->second[axis[r]] = static_cast<int>(r);
    std::vector<std::array<int, 3>> out;
    out.reserve(node_of_point.size());
    for (const auto &[point, d] : node_of_point)
      {
        if (d[0] < 0 || d[1] < 0 || d[2] < 0)
          throw std::logic_error("precompute: a free body's node without three free DoFs");
        out.push_back(d);
      }
    return out;
  }

  /// The nine linear fields W (n x 9): column 3a + c holds x_c - c_c at the DoFs of axis a.
  inline Eigen::MatrixXd
  linear_fields(const std::vector<Vec3> &offset, const std::vector<unsigned char> &axis)
  {
    Eigen::MatrixXd W = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(offset.size()), 9);
    for (size_t r = 0; r < offset.size(); ++r)
      for (unsigned c = 0; c < 3; ++c)
        W(static_cast<Eigen::Index>(r), 3 * axis[r] + c) = offset[r][c];
    return W;
  }

  /// The a-components of the columns of V at the nodes (nodes x V.cols()).
  inline Eigen::MatrixXd
  component(const Eigen::MatrixXd &V, const std::vector<std::array<int, 3>> &nodes, const int a)
  {
    Eigen::MatrixXd out(static_cast<Eigen::Index>(nodes.size()), V.cols());
    for (size_t p = 0; p < nodes.size(); ++p)
      out.row(static_cast<Eigen::Index>(p)) = V.row(nodes[p][a]);
    return out;
  }

  /// J_ab (9 r^2: block 3a + b, each r x r row-major) from the a-components of r modes and the
  /// b-components of M_s times them.
  inline std::vector<double>
  inertial_blocks(const std::array<Eigen::MatrixXd, 3> &phi, const std::array<Eigen::MatrixXd, 3> &m_phi)
  {
    const auto   r  = static_cast<size_t>(phi[0].cols());
    const size_t r2 = r * r;
    std::vector<double> out(9 * r2, 0.0);
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          &out[(3 * a + b) * r2], phi[a].cols(), phi[a].cols()) = phi[a].transpose() * m_phi[b];
    return out;
  }
} // namespace irdm::fem::frame_couplings
