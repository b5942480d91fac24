#pragma once
// The reduced residual's element forces, four cubature elements at a time: the neo-Hookean law
// and the objective damping of irdm_common/neo_hookean_tet.h (the one-kernel
// damped_neo_hookean_force), the same arithmetic in double with the four elements in the lanes
// of one vector (AVX2/FMA where the CPU has it; a portable build of the same code else). Each
// residual evaluates every cubature element's force, so this is the step's largest cost after
// the products with U's rows; the tangent's element matrices stay with the one-element kernels.
#include <irdm/element_lanes.h>
#include <irdm_common/neo_hookean_tet.h>

#include <cstddef>
#include <vector>

namespace irdm::detail
{
  /// The elements in groups of four, in order (the last group padded).
  std::vector<ElementLanes>
  pack_element_lanes(const std::vector<elastic::Tetrahedron>   &elements,
                     const std::vector<double>                 &weights,
                     const std::vector<std::array<unsigned, 4>> &vertices);

  /// f += each element's weighted force, the law's at nodal displacements u plus beta times the
  /// damping's at nodal velocities v (both 3 per vertex; v unread where beta is 0), added to
  /// its vertices element after element, in order. Returns the number of inverted elements
  /// (J <= 0), whose force is left out.
  unsigned
  damped_neo_hookean_forces_portable(const ElementLanes *groups, std::size_t n_groups,
                                     const double *u, const double *v, double mu, double lambda,
                                     double beta, double *f);
  unsigned
  damped_neo_hookean_forces_avx2(const ElementLanes *groups, std::size_t n_groups,
                                 const double *u, const double *v, double mu, double lambda,
                                 double beta, double *f);
  /// The faster of the two this CPU runs (decided once).
  unsigned
  damped_neo_hookean_forces(const ElementLanes *groups, std::size_t n_groups, const double *u,
                            const double *v, double mu, double lambda, double beta, double *f);
} // namespace irdm::detail
