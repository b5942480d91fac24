// ElasticDynamics: the dense free system and the boundary, for the impulse-response precompute.
#include "elastodynamics_impl.h"

#include <algorithm>
#include <set>

namespace irdm::fem
{
  std::vector<int>
  ElasticDynamics::Impl::free_of_dof() const
  {
    std::vector<int> out(dof_handler.n_dofs(), -1);
    int              next = 0;
    for (unsigned i = 0; i < out.size(); ++i)
      if (!constraints.is_constrained(i))
        out[i] = next++;
    return out;
  }

  std::vector<int>
  ElasticDynamics::vertex_dof_to_free() const
  {
    const Impl            &m           = *impl_;
    const std::vector<int> free_of_dof = m.free_of_dof();
    std::vector<int>       out(3 * m.mesh.vertices.size(), -1);
    for (unsigned v = 0; v < m.dofs_of_vertex.size(); ++v)
      for (unsigned d = 0; d < 3; ++d)
        out[3 * v + d] = free_of_dof[m.dofs_of_vertex[v][d]];
    return out;
  }

  DenseSystem
  ElasticDynamics::dense_free_system() const
  {
    const Impl            &m           = *impl_;
    const unsigned         n           = m.dof_handler.n_dofs();
    const std::vector<int> free_of_dof = m.free_of_dof();
    DenseSystem            out;
    out.n_free = static_cast<unsigned>(std::count_if(free_of_dof.begin(), free_of_dof.end(),
                                                      [](int f) { return f >= 0; }));
    const size_t nf = out.n_free;
    out.stiffness.assign(nf * nf, 0.0);
    out.mass.assign(nf * nf, 0.0);
    for (unsigned row = 0; row < n; ++row)
      {
        if (free_of_dof[row] < 0)
          continue;
        const size_t r = free_of_dof[row];
        for (auto it = m.stiffness.begin(row); it != m.stiffness.end(row); ++it)
          if (free_of_dof[it->column()] >= 0)
            out.stiffness[r * nf + free_of_dof[it->column()]] = it->value();
        for (auto it = m.mass.begin(row); it != m.mass.end(row); ++it)
          if (free_of_dof[it->column()] >= 0)
            out.mass[r * nf + free_of_dof[it->column()]] = it->value();
      }
    out.vertex_dof_to_free = vertex_dof_to_free();
    m.free_dof_geometry(out.free_dof_offset, out.free_dof_axis);
    return out;
  }

  void
  ElasticDynamics::Impl::free_dof_geometry(std::vector<Vec3>          &offset,
                                           std::vector<unsigned char> &axis) const
  {
    const std::vector<int> free = free_of_dof();
    const auto nf = static_cast<size_t>(std::count_if(free.begin(), free.end(), [](int f) { return f >= 0; }));
    offset.resize(nf);
    axis.resize(nf);
    const auto                  c = mass_properties(mesh, scene.density).center;
    const std::vector<Point<3>> x = dof_support_points();
    for (unsigned i = 0; i < free.size(); ++i)
      if (free[i] >= 0)
        {
          offset[free[i]] = {x[i][0] - c[0], x[i][1] - c[1], x[i][2] - c[2]};
          axis[free[i]]   = dof_component[i];
        }
  }

  SurfaceMesh
  ElasticDynamics::boundary() const
  {
    const Impl &m = *impl_;
    SurfaceMesh out;
    std::map<int, std::string> name_of_tag;
    for (const auto &[name, tag] : m.mesh.surface_names)
      name_of_tag[tag] = name;
    std::vector<int> local(m.mesh.vertices.size(), -1);
    for (const unsigned v : m.surface_vertices)
      {
        local[v] = static_cast<int>(out.mesh_vertex.size());
        out.mesh_vertex.push_back(v);
        out.node_tags.push_back(m.mesh.node_tags[v]);
        out.coordinates.push_back(m.mesh.vertices[v]);
      }
    for (unsigned t = 0; t < m.surface_triangles.size(); ++t)
      {
        const auto &tri = m.surface_triangles[t];
        out.triangles.push_back({static_cast<unsigned>(local[tri[0]]),
                                 static_cast<unsigned>(local[tri[1]]),
                                 static_cast<unsigned>(local[tri[2]])});
        const auto it = name_of_tag.find(m.surface_triangle_tag[t]);
        out.triangle_surface.push_back(it == name_of_tag.end() ? std::string() : it->second);
      }
    return out;
  }
} // namespace irdm::fem
