#pragma once
// Four cubature elements in the lanes of one vector: the reduced residual's element kernels
// (irdm/src/element_forces.h) read them.
#include <array>

namespace irdm::detail
{
  /// Four elements, one per lane: component b of node i's shape-function gradient (1/m) at
  /// grad[b][i][lane], the element's cubature weight times its volume (m^3), and its four
  /// nodes' cubature vertices. Lanes past `lanes` are padding (zero gradients and weight: never
  /// inverted, no force).
  struct ElementLanes
  {
    alignas(32) double grad[3][4][4];
    alignas(32) double weight_volume[4];
    std::array<std::array<unsigned, 4>, 4> vertex; // [lane][node]
    int                                    lanes = 0;
  };
} // namespace irdm::detail
