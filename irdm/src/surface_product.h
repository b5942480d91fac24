#pragma once
// The modal surface update's matrix-vector product u = Phi_M a, Phi_M stored [output][mode]
// row-major in single precision (ModalModel::shapes), a and u in double, the sums in double.
// It is the full surface update's cost (100 modes x 1554 outputs): streaming Phi_M, so the
// shapes are floats (half the bytes), and it has an AVX2/FMA kernel chosen at run time,
// besides the portable one that the build's own flags give (x86-64: SSE2 only). Both are
// here so that a test can hold them to each other.
#include <cstddef>

namespace irdm::detail
{
  // u[j] = sum_m shapes[j * M + m] * a[m], j < n_outputs.
  void
  surface_product_portable(const float *shapes, std::size_t M, std::size_t n_outputs,
                           const double *a, double *u);

  // True if this CPU runs surface_product_avx2 (x86-64 with AVX2 and FMA).
  bool
  surface_product_avx2_available();

  // The same product with 256-bit FMA; call only if surface_product_avx2_available().
  void
  surface_product_avx2(const float *shapes, std::size_t M, std::size_t n_outputs,
                       const double *a, double *u);

  // The fastest of the two this CPU runs (decided once).
  void
  surface_product(const float *shapes, std::size_t M, std::size_t n_outputs, const double *a,
                  double *u);
} // namespace irdm::detail
