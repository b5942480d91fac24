#include <irdm_common/error.h>
#include <reference_fem/mesh.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <unordered_map>

namespace irdm::fem
{
  namespace
  {
    [[noreturn]] void
    fail(const std::string &file, const std::string &what)
    {
      throw InputError("mesh '" + file + "': " + what);
    }

    struct RawElement
    {
      int                    type;
      int                    tag; // physical tag (0 if none)
      std::vector<long long> nodes;
    };

    // Nodes per gmsh element type for the types we may meet; second-order ones are rejected.
    int
    nodes_of_type(const int type)
    {
      switch (type)
        {
          case 15: return 1; // point
          case 1:  return 2; // line
          case 2:  return 3; // triangle
          case 3:  return 4; // quadrangle
          case 4:  return 4; // tetrahedron
          case 5:  return 8; // hexahedron
          case 6:  return 6; // prism
          case 7:  return 5; // pyramid
          case 8:  return 3; // line3
          case 9:  return 6; // triangle6
          case 11: return 10; // tetrahedron10
          default: return -1;
        }
    }
  } // namespace

  double
  signed_volume(const std::array<double, 3> &a,
                const std::array<double, 3> &b,
                const std::array<double, 3> &c,
                const std::array<double, 3> &d)
  {
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
            u[2] * (v[0] * w[1] - v[1] * w[0])) /
           6.0;
  }

  MassProperties
  mass_properties(const TetMesh &mesh, const double density)
  {
    MassProperties out;
    if (mesh.tets.empty())
      return out;
    // Moments about a vertex of the mesh, not the origin: no cancellation for a body far away.
    const std::array<double, 3> o = mesh.vertices[mesh.tets[0][0]];
    const auto shifted = [&](const unsigned v) {
      return std::array<double, 3>{mesh.vertices[v][0] - o[0], mesh.vertices[v][1] - o[1],
                                   mesh.vertices[v][2] - o[2]};
    };
    double volume = 0, first[3] = {0, 0, 0}, second[3][3] = {};
    for (const auto &tet : mesh.tets)
      {
        const auto   a = shifted(tet[0]), b = shifted(tet[1]), c = shifted(tet[2]),
                   d = shifted(tet[3]);
        const double v = signed_volume(a, b, c, d);
        double       sum[3];
        for (int i = 0; i < 3; ++i)
          sum[i] = a[i] + b[i] + c[i] + d[i];
        volume += v;
        for (int i = 0; i < 3; ++i)
          {
            first[i] += v * sum[i] / 4;
            for (int j = 0; j < 3; ++j)
              second[i][j] += v / 20 *
                              (a[i] * a[j] + b[i] * b[j] + c[i] * c[j] + d[i] * d[j] + sum[i] * sum[j]);
          }
      }
    out.mass = density * volume;
    for (int i = 0; i < 3; ++i)
      out.center[i] = first[i] / volume; // about o, until below
    // About the centre: int r_i r_j = second - V c_i c_j; I = rho (tr(.) delta - (.)).
    double central[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        central[i][j] = second[i][j] - volume * out.center[i] * out.center[j];
    const double trace = central[0][0] + central[1][1] + central[2][2];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        out.inertia[i][j] = density * ((i == j ? trace : 0.0) - central[i][j]);
    for (int i = 0; i < 3; ++i)
      out.center[i] += o[i];
    return out;
  }

  std::string
  file_hash(const std::string &path)
  {
    std::ifstream in(path, std::ios::binary);
    if (!in)
      throw InputError("cannot read '" + path + "'");
    unsigned long long h = 1469598103934665603ULL;
    char               buf[65536];
    while (in.read(buf, sizeof buf) || in.gcount() > 0)
      for (std::streamsize i = 0; i < in.gcount(); ++i)
        {
          h ^= static_cast<unsigned char>(buf[i]);
          h *= 1099511628211ULL;
        }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", h);
    return hex;
  }

  int
  TetMesh::surface_tag(const std::string &name) const
  {
    const auto it = surface_names.find(name);
    if (it != surface_names.end())
      return it->second;
    std::string list;
    for (const auto &kv : surface_names)
      list += (list.empty() ? "" : ", ") + kv.first;
    throw InputError("mesh '" + file + "' has no physical surface named '" + name +
                     "' (it has: " + (list.empty() ? "none" : list) + ")");
  }

  unsigned
  TetMesh::vertex_of_node_tag(const long long tag) const
  {
    for (unsigned i = 0; i < node_tags.size(); ++i)
      if (node_tags[i] == tag)
        return i;
    throw InputError("mesh '" + file + "' has no vertex with node tag " +
                     std::to_string(tag));
  }

  namespace
  {
    // The sections of an ASCII gmsh file (MSH 2.2 or 4.1) read into nodes, raw elements and
    // names; then the tetrahedra and tagged triangles checked and indexed (TetMesh). Every
    // count in the file is checked against the file's size before anything is sized by it:
    // each node, element or name takes at least 2 bytes, so no honest count exceeds the size.
    // A header claiming 1e18 nodes is refused at once instead of looping.
    class GmshReader
    {
    public:
      explicit GmshReader(const std::string &path)
        : path_(path)
        , in_(path)
      {
        if (!in_)
          fail(path, "cannot open the file");
        std::error_code size_error;
        file_size_ = std::filesystem::file_size(path, size_error);
        if (size_error)
          fail(path, "cannot read its size: " + size_error.message());
        mesh_.file = path;
      }

      TetMesh
      read()
      {
        std::string line;
        while (std::getline(in_, line))
          {
            if (!line.empty() && line.back() == '\r')
              line.pop_back();
            if (line == "$MeshFormat")
              read_format();
            else if (line == "$PhysicalNames")
              read_physical_names();
            else if (line == "$Entities" && version_ >= 4)
              read_entities();
            else if (line == "$Nodes")
              read_nodes();
            else if (line == "$Elements")
              read_elements();
          }
        if (version_ == 0)
          fail(path_, "no $MeshFormat section: not a gmsh .msh file");
        add_tetrahedra();
        add_triangles();
        return std::move(mesh_);
      }

    private:
      std::string                                          path_;
      std::ifstream                                        in_;
      std::size_t                                          file_size_ = 0;
      double                                               version_   = 0;
      std::unordered_map<long long, std::array<double, 3>> nodes_;
      std::vector<RawElement>                              elements_;
      std::map<std::pair<int, int>, int>                   entity_tag_; // (dim, entity) -> physical
      std::unordered_map<long long, unsigned>              index_of_tag_;
      TetMesh                                              mesh_;

      void
      check_count(const long long n, const char *what) const
      {
        if (n < 0 || static_cast<unsigned long long>(n) > file_size_ / 2)
          fail(path_, std::string("the file claims ") + std::to_string(n) + " " + what +
                        ", which a file of " + std::to_string(file_size_) + " bytes cannot hold");
      }
      void
      expect(const std::istream &s, const char *what) const
      {
        if (!s)
          fail(path_, std::string("malformed ") + what + " section");
      }

      void
      read_format()
      {
        int file_type = 0, data_size = 0;
        in_ >> version_ >> file_type >> data_size;
        expect(in_, "$MeshFormat");
        if (file_type != 0)
          fail(path_, "binary .msh is not supported; save as ASCII");
        if (version_ != 2.2 && !(version_ >= 4.0 && version_ < 4.2))
          fail(path_, "MSH version " + std::to_string(version_) + " is not supported (2.2 or 4.1)");
      }

      void
      read_physical_names()
      {
        const long long n = read_count("$PhysicalNames", "physical names");
        std::string line;
        std::getline(in_, line);
        for (long long i = 0; i < n; ++i)
          {
            if (!std::getline(in_, line))
              fail(path_, "the $PhysicalNames section ends early");
            std::istringstream s(line);
            int                dim = 0, tag = 0;
            s >> dim >> tag;
            const auto q1 = line.find('"'), q2 = line.rfind('"');
            if (!s || q1 == std::string::npos || q2 <= q1)
              fail(path_, "malformed $PhysicalNames line '" + line + "'");
            const std::string name = line.substr(q1 + 1, q2 - q1 - 1);
            (dim == 2 ? mesh_.surface_names : mesh_.volume_names)[name] = tag;
          }
      }

      // MSH 4: only the physical tag of each surface and volume entity matters here.
      void
      read_entities()
      {
        long long n[4] = {0, 0, 0, 0};
        in_ >> n[0] >> n[1] >> n[2] >> n[3];
        expect(in_, "$Entities");
        for (const long long c : n)
          check_count(c, "entities");
        std::string line;
        std::getline(in_, line);
        for (int dim = 0; dim < 4; ++dim)
          for (long long i = 0; i < n[dim]; ++i)
            {
              if (!std::getline(in_, line))
                fail(path_, "the $Entities section ends early");
              std::istringstream s(line);
              int                tag = 0;
              double             box;
              s >> tag;
              for (int k = 0; k < (dim == 0 ? 3 : 6); ++k)
                s >> box;
              long long n_phys = 0;
              s >> n_phys;
              if (n_phys < 0)
                fail(path_, "an entity has a negative number of physical tags");
              int phys = 0;
              if (n_phys > 1)
                fail(path_, "an entity has more than one physical tag");
              if (n_phys == 1)
                s >> phys;
              expect(s, "$Entities");
              entity_tag_[{dim, tag}] = phys;
            }
      }

      // A section's count of items (MSH 2.2, and $PhysicalNames).
      long long
      read_count(const char *section, const char *what)
      {
        long long n = 0;
        in_ >> n;
        expect(in_, section);
        check_count(n, what);
        return n;
      }
      // MSH 4: a section's header (blocks, items, least and largest tag), its block count
      // returned; and a block's header (dimension, entity, a kind: parametric for nodes, the
      // element type for elements; items).
      long long
      read_blocks(const char *section, const char *blocks_what, const char *items_what)
      {
        long long blocks = 0, n = 0, min_tag = 0, max_tag = 0;
        in_ >> blocks >> n >> min_tag >> max_tag;
        expect(in_, section);
        check_count(blocks, blocks_what);
        check_count(n, items_what);
        return blocks;
      }
      struct Block
      {
        int       dim = 0, entity = 0, kind = 0;
        long long count = 0;
      };
      Block
      read_block(const char *section, const char *items_what)
      {
        Block b;
        in_ >> b.dim >> b.entity >> b.kind >> b.count;
        expect(in_, section);
        check_count(b.count, items_what);
        return b;
      }

      void
      add_node(const long long tag, const std::array<double, 3> &x)
      {
        expect(in_, "$Nodes");
        if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]))
          fail(path_, "node " + std::to_string(tag) + " has a coordinate that is not finite");
        if (!nodes_.emplace(tag, x).second)
          fail(path_, "node tag " + std::to_string(tag) + " is defined twice");
      }

      void
      read_nodes()
      {
        if (version_ < 4)
          {
            const long long n = read_count("$Nodes", "nodes");
            for (long long i = 0; i < n; ++i)
              {
                long long             tag = 0;
                std::array<double, 3> x{};
                in_ >> tag >> x[0] >> x[1] >> x[2];
                add_node(tag, x);
              }
            return;
          }
        const long long blocks = read_blocks("$Nodes", "node blocks", "nodes");
        for (long long b = 0; b < blocks; ++b)
          {
            const Block block = read_block("$Nodes", "nodes in a block");
            if (block.kind) // parametric
              fail(path_, "parametric nodes are not supported");
            std::vector<long long> tags(static_cast<std::size_t>(block.count));
            for (auto &t : tags)
              in_ >> t;
            for (const auto t : tags)
              {
                std::array<double, 3> x{};
                in_ >> x[0] >> x[1] >> x[2];
                add_node(t, x);
              }
          }
      }

      void
      read_element_nodes(std::istream &s, RawElement &e) const
      {
        const int nn = nodes_of_type(e.type);
        if (nn < 0)
          fail(path_, "unsupported gmsh element type " + std::to_string(e.type));
        e.nodes.resize(nn);
        for (auto &v : e.nodes)
          s >> v;
        expect(s, "$Elements");
      }

      void
      read_elements()
      {
        if (version_ < 4)
          {
            const long long n = read_count("$Elements", "elements");
            for (long long i = 0; i < n; ++i)
              {
                long long  tag = 0;
                int        n_tags = 0;
                RawElement e;
                in_ >> tag >> e.type >> n_tags;
                expect(in_, "$Elements");
                if (n_tags < 0 || n_tags > 64)
                  fail(path_, "an element has " + std::to_string(n_tags) + " tags (0 to 64)");
                std::vector<int> tags(static_cast<std::size_t>(n_tags));
                for (auto &t : tags)
                  in_ >> t;
                e.tag = n_tags > 0 ? tags[0] : 0;
                read_element_nodes(in_, e);
                elements_.push_back(std::move(e));
              }
            expect(in_, "$Elements");
            return;
          }
        const long long blocks = read_blocks("$Elements", "element blocks", "elements");
        for (long long b = 0; b < blocks; ++b)
          {
            const Block block = read_block("$Elements", "elements in a block");
            const auto  it    = entity_tag_.find({block.dim, block.entity});
            const int   phys  = it == entity_tag_.end() ? 0 : it->second;
            for (long long i = 0; i < block.count; ++i)
              {
                long long  tag = 0;
                RawElement e;
                e.type = block.kind;
                e.tag  = phys;
                in_ >> tag;
                read_element_nodes(in_, e);
                elements_.push_back(std::move(e));
              }
          }
        expect(in_, "$Elements");
      }

      // The mesh's vertex of a node tag, added at its first use by a tetrahedron.
      unsigned
      vertex_index(const long long tag)
      {
        const auto it = index_of_tag_.find(tag);
        if (it != index_of_tag_.end())
          return it->second;
        const auto nt = nodes_.find(tag);
        if (nt == nodes_.end())
          fail(path_, "an element refers to the missing node " + std::to_string(tag));
        const unsigned i = static_cast<unsigned>(mesh_.vertices.size());
        mesh_.vertices.push_back(nt->second);
        mesh_.node_tags.push_back(tag);
        index_of_tag_[tag] = i;
        return i;
      }

      // Volume elements: linear tetrahedra only, none flat, inverted or repeated.
      void
      add_tetrahedra()
      {
        std::size_t element_no = 0;
        std::map<std::array<unsigned, 4>, std::size_t> tet_of_vertices; // sorted vertices -> number
        for (const auto &e : elements_)
          {
            ++element_no;
            if (e.type == 11 || e.type == 9 || e.type == 8)
              fail(path_, "second-order elements found: export linear tetrahedra "
                          "(Mesh.ElementOrder = 1); the FEM adds P2 itself");
            if (e.type == 5 || e.type == 6 || e.type == 7)
              fail(path_, "only tetrahedra are supported as volume elements");
            if (e.type != 4)
              continue;
            std::array<unsigned, 4> t;
            for (int k = 0; k < 4; ++k)
              t[k] = vertex_index(e.nodes[k]);
            const auto &a = mesh_.vertices[t[0]], &b = mesh_.vertices[t[1]],
                       &c = mesh_.vertices[t[2]], &d = mesh_.vertices[t[3]];
            const double vol     = signed_volume(a, b, c, d);
            double       longest = 0;
            for (int i = 0; i < 4; ++i)
              for (int j = i + 1; j < 4; ++j)
                {
                  const auto &p = mesh_.vertices[t[i]], &q = mesh_.vertices[t[j]];
                  longest = std::max(longest, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
                }
            // A regular tetrahedron has V = 0.118 L^3; 1e-6 L^3 is flat by any standard.
            if (std::abs(vol) <= 1e-6 * longest * longest * longest)
              fail(path_, "tetrahedron " + std::to_string(element_no) + " is degenerate (volume " +
                            std::to_string(vol) + " m^3)");
            if (vol < 0)
              fail(path_, "tetrahedron " + std::to_string(element_no) +
                            " is inverted (negative volume); the mesh is corrupt");
            std::array<unsigned, 4> key = t;
            std::sort(key.begin(), key.end());
            const auto [seen, is_new] = tet_of_vertices.emplace(key, element_no);
            if (!is_new)
              fail(path_, "tetrahedron " + std::to_string(element_no) + " repeats element " +
                            std::to_string(seen->second) + " (the same four nodes)");
            mesh_.tets.push_back(t);
            mesh_.tet_tags.push_back(e.tag);
          }
        if (mesh_.tets.empty())
          fail(path_, "no tetrahedra (with physical groups defined, gmsh saves only "
                      "elements in a Physical Volume)");
      }

      // Triangles in a physical surface, on the tetrahedra's vertices.
      void
      add_triangles()
      {
        for (const auto &e : elements_)
          if (e.type == 2 && e.tag != 0)
            {
              std::array<unsigned, 3> t;
              for (int k = 0; k < 3; ++k)
                {
                  const auto it = index_of_tag_.find(e.nodes[k]);
                  if (it == index_of_tag_.end())
                    fail(path_, "a tagged triangle has a node on no tetrahedron");
                  t[k] = it->second;
                }
              if (e.tag < 1 || e.tag > 250)
                fail(path_, "physical surface tag " + std::to_string(e.tag) + " outside 1..250");
              mesh_.triangles.push_back(t);
              mesh_.triangle_tags.push_back(e.tag);
            }
      }
    };
  } // namespace

  TetMesh
  read_gmsh(const std::string &path)
  {
    return GmshReader(path).read();
  }
} // namespace irdm::fem
