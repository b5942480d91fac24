#pragma once
// Internal, plain C++: a model's input or output region as surface vertices, shared by the
// impulse-response precompute (impulse_response.cc) and the reduced model (reduced_model.cc).
#include <reference_fem/elastodynamics.h>

#include <optional>
#include <string>
#include <vector>

namespace irdm::fem
{
  /// The free surface vertices (indices into b) in a region (every free surface vertex when
  /// unset), in boundary order. InputError for an unknown surface or an empty region.
  std::vector<unsigned>
  select_vertices(const std::optional<VertexRegion> &region, const SurfaceMesh &b,
                  const std::vector<int> &vertex_dof_to_free, const std::string &what);
} // namespace irdm::fem
