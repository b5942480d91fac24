#pragma once
// Internal to validation/: other meshes of the same body (a finer mesh's truth). A run's surface
// displacement read at the vertices of another surface of the body (that truth at the methods'
// surface vertices): each vertex takes the displacement of the run's surface point closest to
// it, barycentric on its triangle.
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace irdm::validation
{
  /// The nonlinear FEM's method name at P<degree>: fem_neo_hookean_p<degree> on the scene's own
  /// mesh (mesh_file empty), fem_neo_hookean_p<degree>_<mesh file stem> on another.
  inline std::string
  truth_name(const unsigned degree, const std::string &mesh_file)
  {
    const std::string p = "fem_neo_hookean_p" + std::to_string(degree);
    return mesh_file.empty() ? p : p + "_" + std::filesystem::path(mesh_file).stem().string();
  }

  /// A finer mesh of the body must fill the body's box (within 5 % of its diagonal): another
  /// body, other units or another placement would give rows of nothing, read at points of the
  /// wrong surface. `what` names the other mesh in the error.
  template <typename Vertices>
  void
  check_same_body(const Vertices &body, const Vertices &other, const std::string &what)
  {
    const auto box = [](const Vertices &vertices) {
      std::array<double, 6> b{INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY};
      for (const auto &x : vertices)
        for (int d = 0; d < 3; ++d)
          b[d] = std::min(b[d], double(x[d])), b[3 + d] = std::max(b[3 + d], double(x[d]));
      return b;
    };
    const auto a = box(body), b = box(other);
    double     gap = 0, diagonal = 0;
    for (int d = 0; d < 3; ++d)
      {
        gap = std::max({gap, std::abs(a[d] - b[d]), std::abs(a[3 + d] - b[3 + d])});
        diagonal += (a[3 + d] - a[d]) * (a[3 + d] - a[d]);
      }
    if (other.empty() || !(gap <= 0.05 * std::sqrt(diagonal)))
      throw InputError(what + " is not a mesh of the scene's body: its box is " +
                       std::to_string(1e3 * gap) + " mm from the body's");
  }

  struct SurfaceTransfer
  {
    std::vector<std::array<unsigned, 3>> vertices; // of the run's surface, per target vertex
    std::vector<std::array<double, 3>>   weights;
    double gap = 0; // m: the largest distance from a target vertex to the run's surface
  };

  /// From the run's surface (rest coordinates, outward triangles) to the points `to` (rest, m).
  template <typename Vertices, typename Triangles, typename Points>
  SurfaceTransfer
  surface_transfer(const Vertices &from, const Triangles &triangles, const Points &to)
  {
    SurfaceTransfer t;
    if (triangles.size() == 0)
      throw InputError("surface transfer: the run has no surface");
    for (const auto &x : to)
      {
        const auto p = geometry::closest_point(from, triangles, geometry::Point{x[0], x[1], x[2]});
        t.vertices.push_back(triangles[p.triangle]);
        t.weights.push_back(p.weights);
        t.gap = std::max(t.gap, std::sqrt(p.distance_squared));
      }
    return t;
  }

  /// The run's displacement (3 per surface vertex) at the target vertices (3 per vertex).
  inline std::vector<double>
  transferred(const SurfaceTransfer &t, const std::vector<double> &u)
  {
    std::vector<double> v(3 * t.vertices.size(), 0.0);
    for (size_t i = 0; i < t.vertices.size(); ++i)
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a)
          v[3 * i + a] += t.weights[i][j] * u[3 * t.vertices[i][j] + a];
    return v;
  }
} // namespace irdm::validation
