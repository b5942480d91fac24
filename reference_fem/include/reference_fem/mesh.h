#pragma once
// A linear tetrahedral mesh as read from a gmsh .msh file (ASCII, format 2.2 or 4.1),
// checked before any FEM sees it: no second-order, inverted or degenerate elements, and the
// physical names resolved. Plain C++ (no deal.II).
#include <array>
#include <map>
#include <string>
#include <vector>

namespace irdm::fem
{
  struct TetMesh
  {
    std::string                            file;
    std::vector<std::array<double, 3>>     vertices;  // m; only vertices used by tetrahedra
    std::vector<long long>                 node_tags; // gmsh node tag of each vertex
    std::vector<std::array<unsigned, 4>>   tets;      // positively oriented
    std::vector<int>                       tet_tags;  // physical volume tag
    std::vector<std::array<unsigned, 3>>   triangles; // tagged boundary triangles
    std::vector<int>                       triangle_tags;
    std::map<std::string, int>             surface_names; // physical surface name -> tag
    std::map<std::string, int>             volume_names;

    /// The tag of a named physical surface; InputError listing the names if absent.
    int
    surface_tag(const std::string &name) const;
    /// Vertex index of a gmsh node tag; InputError if it is not a vertex of a tetrahedron.
    unsigned
    vertex_of_node_tag(long long tag) const;
  };

  /// Reads and checks a gmsh mesh; throws InputError naming the file and the problem.
  TetMesh
  read_gmsh(const std::string &path);

  /// Signed volume of a tetrahedron (positive for gmsh's orientation).
  double
  signed_volume(const std::array<double, 3> &a,
                const std::array<double, 3> &b,
                const std::array<double, 3> &c,
                const std::array<double, 3> &d);

  /// Mass properties of a body of uniform density filling the mesh, exact for its straight
  /// tetrahedra (closed form: int x_i x_j dV = V/20 (sum_a x_ai x_aj + S_i S_j) over a
  /// tetrahedron, S the sum of its 4 vertices; Tonon, J. Math. Stat. 1, 2004).
  struct MassProperties
  {
    double                               mass = 0;   // kg
    std::array<double, 3>                center{};   // m, centre of mass
    std::array<std::array<double, 3>, 3> inertia{};  // kg m^2, about the centre of mass
  };

  MassProperties
  mass_properties(const TetMesh &mesh, double density);

  /// FNV-1a 64-bit hash of a file's bytes, as 16 hex digits: identifies the mesh a result
  /// or model was made from.
  std::string
  file_hash(const std::string &path);
} // namespace irdm::fem
