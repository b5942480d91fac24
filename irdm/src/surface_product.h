#pragma once
// Products of a row-major matrix stored in single precision with vectors in double.
// The modal surface update's u = Phi_M a (ModalModel::shapes, [output][mode]) is the full
// surface update's cost (100 modes x 1554 outputs): streaming Phi_M, so the shapes are floats
// (half the bytes). Three kernels: the portable one that the build's own flags give (x86-64:
// SSE2 only) and an AVX2/FMA one, both summing in double, and the one the runtime takes where
// the CPU has AVX2 and FMA: AVX2/FMA summing in single precision (eight modes per instruction;
// its rounding is of the order of the shapes' own storage). The reduced nonlinear model's rows
// of U take the kernels that sum in double (rows_product, rows_product2 and the transposed
// product): Newton drives its residual far below float's rounding. Every kernel is here so that
// a test can hold them to an exact sum and a benchmark to each other.
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

  // The same product in single-precision arithmetic (a rounded to float, float sums of about
  // M / 8 terms per lane, the eight lane sums of a row added in float and widened to double);
  // call only if surface_product_avx2_available().
  void
  surface_product_avx2_single(const float *shapes, std::size_t M, std::size_t n_outputs,
                              const double *a, double *u);

  // The fastest this CPU runs (decided once).
  void
  surface_product(const float *shapes, std::size_t M, std::size_t n_outputs, const double *a,
                  double *u);

  // The fastest of the two that sum in double (decided once): where the product must be the
  // rounded rows' own to double round-off (the reduced nonlinear model's residual, which
  // Newton drives to 1e-8 of its forces).
  void
  rows_product(const float *rows, std::size_t M, std::size_t n_rows, const double *a, double *u);

  // Two products over one pass of the rows, u = rows a and v = rows b, summed in double (the
  // rows are read from memory once): portable, AVX2/FMA, and the faster (decided once).
  void
  rows_product2_portable(const float *rows, std::size_t M, std::size_t n_rows, const double *a,
                         const double *b, double *u, double *v);
  void
  rows_product2_avx2(const float *rows, std::size_t M, std::size_t n_rows, const double *a,
                     const double *b, double *u, double *v);
  void
  rows_product2(const float *rows, std::size_t M, std::size_t n_rows, const double *a,
                const double *b, double *u, double *v);

  // The transposed product g[m] = sum_j rows[j * M + m] * f[j], m < M, summed in double: the
  // forces at the rows' points back onto the basis. Portable and AVX2/FMA (four rows a pass),
  // and the faster (decided once).
  void
  transposed_rows_product_portable(const float *rows, std::size_t M, std::size_t n_rows,
                                   const double *f, double *g);
  void
  transposed_rows_product_avx2(const float *rows, std::size_t M, std::size_t n_rows,
                               const double *f, double *g);
  void
  transposed_rows_product(const float *rows, std::size_t M, std::size_t n_rows, const double *f,
                          double *g);
} // namespace irdm::detail
