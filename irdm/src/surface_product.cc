#include "surface_product.h"

#include <Eigen/Dense>

#include <algorithm>

#if defined(__x86_64__) && defined(__GNUC__)
#  include <immintrin.h>
#  define IRDM_HAVE_AVX2_KERNEL 1
#endif

namespace irdm::detail
{
  // Each row widened to double a chunk at a time (a loop the compiler vectorizes), then
  // Eigen's vectorized dot product; a plain float-times-double loop would stay scalar (a
  // floating-point reduction is not reordered without -ffast-math).
  void
  surface_product_portable(const float *shapes, const std::size_t M,
                           const std::size_t n_outputs, const double *a, double *u)
  {
    constexpr std::size_t chunk = 64;
    double                wide[chunk];
    for (std::size_t j = 0; j < n_outputs; ++j)
      {
        const float *row = shapes + j * M;
        double       s   = 0;
        for (std::size_t m0 = 0; m0 < M; m0 += chunk)
          {
            const std::size_t c = std::min(chunk, M - m0);
            for (std::size_t i = 0; i < c; ++i)
              wide[i] = static_cast<double>(row[m0 + i]);
            const auto n = static_cast<Eigen::Index>(c);
            s += Eigen::Map<const Eigen::VectorXd>(wide, n).dot(
              Eigen::Map<const Eigen::VectorXd>(a + m0, n));
          }
        u[j] = s;
      }
  }

  // Each row widened a chunk at a time and added in, times its f, with Eigen's vectorized
  // axpy.
  void
  transposed_rows_product_portable(const float *rows, const std::size_t M,
                                   const std::size_t n_rows, const double *f, double *g)
  {
    constexpr std::size_t chunk = 64;
    double                wide[chunk];
    std::fill(g, g + M, 0.0);
    for (std::size_t j = 0; j < n_rows; ++j)
      for (std::size_t m0 = 0; m0 < M; m0 += chunk)
        {
          const std::size_t c = std::min(chunk, M - m0);
          for (std::size_t i = 0; i < c; ++i)
            wide[i] = static_cast<double>(rows[j * M + m0 + i]);
          const auto n = static_cast<Eigen::Index>(c);
          Eigen::Map<Eigen::VectorXd>(g + m0, n) += f[j] * Eigen::Map<const Eigen::VectorXd>(wide, n);
        }
  }

  void
  rows_product2_portable(const float *rows, const std::size_t M, const std::size_t n_rows,
                         const double *a, const double *b, double *u, double *v)
  {
    constexpr std::size_t chunk = 64;
    double                wide[chunk];
    for (std::size_t j = 0; j < n_rows; ++j)
      {
        double su = 0, sv = 0;
        for (std::size_t m0 = 0; m0 < M; m0 += chunk)
          {
            const std::size_t c = std::min(chunk, M - m0);
            for (std::size_t i = 0; i < c; ++i)
              wide[i] = static_cast<double>(rows[j * M + m0 + i]);
            const auto                              n = static_cast<Eigen::Index>(c);
            const Eigen::Map<const Eigen::VectorXd> w(wide, n);
            su += w.dot(Eigen::Map<const Eigen::VectorXd>(a + m0, n));
            sv += w.dot(Eigen::Map<const Eigen::VectorXd>(b + m0, n));
          }
        u[j] = su, v[j] = sv;
      }
  }

#ifdef IRDM_HAVE_AVX2_KERNEL
  bool
  surface_product_avx2_available()
  {
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  }

  namespace
  {
    // The four sums of the lanes of r0..r3, as one vector {sum r0, sum r1, sum r2, sum r3}.
    __attribute__((target("avx2,fma"))) inline __m256d
    lane_sums(const __m256d r0, const __m256d r1, const __m256d r2, const __m256d r3)
    {
      const __m256d s01 = _mm256_hadd_pd(r0, r1); // {r0 01, r1 01, r0 23, r1 23}
      const __m256d s23 = _mm256_hadd_pd(r2, r3);
      return _mm256_add_pd(_mm256_permute2f128_pd(s01, s23, 0x20),
                           _mm256_permute2f128_pd(s01, s23, 0x31));
    }
  } // namespace

  // Eight output rows at a time share each load of a, and their eight independent FMA chains
  // hide the FMA latency (the row loop unrolled: at -O2 GCC would keep acc in memory, twice as
  // slow); the rows are read once, front to back (the cost is streaming Phi_M),
  // four floats at a time widened to double.
  __attribute__((target("avx2,fma"))) void
  surface_product_avx2(const float *shapes, const std::size_t M, const std::size_t n_outputs,
                       const double *a, double *u)
  {
    const std::size_t M4 = M - M % 4;
    std::size_t       j  = 0;
    for (; j + 8 <= n_outputs; j += 8)
      {
        const float  *row = shapes + j * M;
        __m256d       acc[8];
        for (auto &r : acc)
          r = _mm256_setzero_pd();
        for (std::size_t m = 0; m < M4; m += 4)
          {
            const __m256d am = _mm256_loadu_pd(a + m);
            #pragma GCC unroll 8
            for (int r = 0; r < 8; ++r)
              acc[r] = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(row + r * M + m)), am, acc[r]);
          }
        __m256d lo = lane_sums(acc[0], acc[1], acc[2], acc[3]);
        __m256d hi = lane_sums(acc[4], acc[5], acc[6], acc[7]);
        if (M4 < M)
          {
            alignas(32) double tail[8] = {};
            for (int r = 0; r < 8; ++r)
              for (std::size_t m = M4; m < M; ++m)
                tail[r] += static_cast<double>(row[r * M + m]) * a[m];
            lo = _mm256_add_pd(lo, _mm256_load_pd(tail));
            hi = _mm256_add_pd(hi, _mm256_load_pd(tail + 4));
          }
        _mm256_storeu_pd(u + j, lo);
        _mm256_storeu_pd(u + j + 4, hi);
      }
    for (; j < n_outputs; ++j) // the last n_outputs % 8 rows
      {
        double s = 0;
        for (std::size_t m = 0; m < M; ++m)
          s += static_cast<double>(shapes[j * M + m]) * a[m];
        u[j] = s;
      }
  }
  namespace
  {
    // The eight sums of the lanes of r[0..7], as one vector {sum r[0], ..., sum r[7]}.
    __attribute__((target("avx2,fma"))) inline __m256
    lane_sums(const __m256 *r)
    {
      // Two rounds of pairwise adds leave in lane i of the low half a partial sum of row i
      // (rows 0 to 3) or of row i + 4 (the other vector), the high half the rest of the same
      // rows; the last add joins the halves.
      const __m256 s0123 = _mm256_hadd_ps(_mm256_hadd_ps(r[0], r[1]), _mm256_hadd_ps(r[2], r[3]));
      const __m256 s4567 = _mm256_hadd_ps(_mm256_hadd_ps(r[4], r[5]), _mm256_hadd_ps(r[6], r[7]));
      return _mm256_add_ps(_mm256_permute2f128_ps(s0123, s4567, 0x20),
                           _mm256_permute2f128_ps(s0123, s4567, 0x31));
    }
  } // namespace

  // As surface_product_avx2, but the products and sums in single precision: eight modes per
  // FMA instead of four, and no widening. The shapes are floats already, so the rounding this
  // adds (a to float, about M / 8 + 3 float additions per row) is of the order of the
  // storage's own. a goes to float a block of modes at a time, into a buffer on the stack.
  __attribute__((target("avx2,fma"))) void
  surface_product_avx2_single(const float *shapes, const std::size_t M,
                              const std::size_t n_outputs, const double *a, double *u)
  {
    constexpr std::size_t block = 512;
    alignas(32) float     af[block];
    // maskload's mask for the first c % 8 lanes: eight -1 then eight 0, read from 8 - c % 8.
    static constexpr int ones_then_zeros[16] = {-1, -1, -1, -1, -1, -1, -1, -1,
                                                0,  0,  0,  0,  0,  0,  0,  0};
    std::fill(u, u + n_outputs, 0.0);
    for (std::size_t m0 = 0; m0 < M; m0 += block)
      {
        const std::size_t c  = std::min(block, M - m0);
        const std::size_t c8 = c - c % 8;
        for (std::size_t i = 0; i < c; ++i)
          af[i] = static_cast<float>(a[m0 + i]);
        const __m256i tail = _mm256_loadu_si256(
          reinterpret_cast<const __m256i *>(ones_then_zeros + 8 - c % 8));
        std::size_t j = 0;
        for (; j + 8 <= n_outputs; j += 8)
          {
            const float *row = shapes + j * M + m0;
            __m256       acc[8];
            for (auto &r : acc)
              r = _mm256_setzero_ps();
            for (std::size_t m = 0; m < c8; m += 8)
              {
                const __m256 am = _mm256_load_ps(af + m);
                #pragma GCC unroll 8
                for (int r = 0; r < 8; ++r)
                  acc[r] = _mm256_fmadd_ps(_mm256_loadu_ps(row + r * M + m), am, acc[r]);
              }
            if (c8 < c) // the last c % 8 modes, masked: no load passes the end of a row
              {
                const __m256 am = _mm256_maskload_ps(af + c8, tail);
                #pragma GCC unroll 8
                for (int r = 0; r < 8; ++r)
                  acc[r] = _mm256_fmadd_ps(_mm256_maskload_ps(row + r * M + c8, tail), am, acc[r]);
              }
            const __m256 s = lane_sums(acc);
            _mm256_storeu_pd(u + j, _mm256_add_pd(_mm256_loadu_pd(u + j),
                                                  _mm256_cvtps_pd(_mm256_castps256_ps128(s))));
            _mm256_storeu_pd(u + j + 4,
                             _mm256_add_pd(_mm256_loadu_pd(u + j + 4),
                                           _mm256_cvtps_pd(_mm256_extractf128_ps(s, 1))));
          }
        for (; j < n_outputs; ++j) // the last n_outputs % 8 rows
          {
            float s = 0;
            for (std::size_t m = 0; m < c; ++m)
              s += shapes[j * M + m0 + m] * af[m];
            u[j] += static_cast<double>(s);
          }
      }
  }

  // Four rows a pass, each widened once and taken into both sums: eight independent FMA
  // chains.
  __attribute__((target("avx2,fma"))) void
  rows_product2_avx2(const float *rows, const std::size_t M, const std::size_t n_rows,
                     const double *a, const double *b, double *u, double *v)
  {
    const std::size_t M4 = M - M % 4;
    std::size_t       j  = 0;
    for (; j + 4 <= n_rows; j += 4)
      {
        const float *row = rows + j * M;
        __m256d      au[4], av[4];
        for (int r = 0; r < 4; ++r)
          au[r] = _mm256_setzero_pd(), av[r] = _mm256_setzero_pd();
        for (std::size_t m = 0; m < M4; m += 4)
          {
            const __m256d am = _mm256_loadu_pd(a + m), bm = _mm256_loadu_pd(b + m);
            #pragma GCC unroll 4
            for (int r = 0; r < 4; ++r)
              {
                const __m256d w = _mm256_cvtps_pd(_mm_loadu_ps(row + r * M + m));
                au[r]           = _mm256_fmadd_pd(w, am, au[r]);
                av[r]           = _mm256_fmadd_pd(w, bm, av[r]);
              }
          }
        __m256d su = lane_sums(au[0], au[1], au[2], au[3]);
        __m256d sv = lane_sums(av[0], av[1], av[2], av[3]);
        if (M4 < M)
          {
            alignas(32) double tu[4] = {}, tv[4] = {};
            for (int r = 0; r < 4; ++r)
              for (std::size_t m = M4; m < M; ++m)
                tu[r] += static_cast<double>(row[r * M + m]) * a[m],
                  tv[r] += static_cast<double>(row[r * M + m]) * b[m];
            su = _mm256_add_pd(su, _mm256_load_pd(tu));
            sv = _mm256_add_pd(sv, _mm256_load_pd(tv));
          }
        _mm256_storeu_pd(u + j, su);
        _mm256_storeu_pd(v + j, sv);
      }
    for (; j < n_rows; ++j) // the last n_rows % 4 rows
      {
        double su = 0, sv = 0;
        for (std::size_t m = 0; m < M; ++m)
          su += static_cast<double>(rows[j * M + m]) * a[m], sv += static_cast<double>(rows[j * M + m]) * b[m];
        u[j] = su, v[j] = sv;
      }
  }

  // Four rows a pass over g: each load and store of g carries four FMAs.
  __attribute__((target("avx2,fma"))) void
  transposed_rows_product_avx2(const float *rows, const std::size_t M, const std::size_t n_rows,
                               const double *f, double *g)
  {
    const std::size_t M4 = M - M % 4;
    std::fill(g, g + M, 0.0);
    std::size_t j = 0;
    for (; j + 4 <= n_rows; j += 4)
      {
        const float  *row = rows + j * M;
        const __m256d f0 = _mm256_set1_pd(f[j]), f1 = _mm256_set1_pd(f[j + 1]),
                      f2 = _mm256_set1_pd(f[j + 2]), f3 = _mm256_set1_pd(f[j + 3]);
        for (std::size_t m = 0; m < M4; m += 4)
          {
            __m256d gm = _mm256_loadu_pd(g + m);
            gm = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(row + m)), f0, gm);
            gm = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(row + M + m)), f1, gm);
            gm = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(row + 2 * M + m)), f2, gm);
            gm = _mm256_fmadd_pd(_mm256_cvtps_pd(_mm_loadu_ps(row + 3 * M + m)), f3, gm);
            _mm256_storeu_pd(g + m, gm);
          }
        for (std::size_t m = M4; m < M; ++m)
          for (int r = 0; r < 4; ++r)
            g[m] += static_cast<double>(row[r * M + m]) * f[j + r];
      }
    for (; j < n_rows; ++j) // the last n_rows % 4 rows
      for (std::size_t m = 0; m < M; ++m)
        g[m] += static_cast<double>(rows[j * M + m]) * f[j];
  }
#else
  bool
  surface_product_avx2_available()
  {
    return false;
  }

  void
  transposed_rows_product_avx2(const float *rows, const std::size_t M, const std::size_t n_rows,
                               const double *f, double *g)
  {
    transposed_rows_product_portable(rows, M, n_rows, f, g);
  }

  void
  rows_product2_avx2(const float *rows, const std::size_t M, const std::size_t n_rows,
                     const double *a, const double *b, double *u, double *v)
  {
    rows_product2_portable(rows, M, n_rows, a, b, u, v);
  }

  void
  surface_product_avx2(const float *shapes, const std::size_t M, const std::size_t n_outputs,
                       const double *a, double *u)
  {
    surface_product_portable(shapes, M, n_outputs, a, u);
  }

  void
  surface_product_avx2_single(const float *shapes, const std::size_t M,
                              const std::size_t n_outputs, const double *a, double *u)
  {
    surface_product_portable(shapes, M, n_outputs, a, u);
  }
#endif

  void
  surface_product(const float *shapes, const std::size_t M, const std::size_t n_outputs,
                  const double *a, double *u)
  {
    static const bool avx2 = surface_product_avx2_available(); // thread-safe, decided once
    if (avx2)
      surface_product_avx2_single(shapes, M, n_outputs, a, u);
    else
      surface_product_portable(shapes, M, n_outputs, a, u);
  }

  void
  rows_product(const float *rows, const std::size_t M, const std::size_t n_rows, const double *a,
               double *u)
  {
    static const bool avx2 = surface_product_avx2_available();
    if (avx2)
      surface_product_avx2(rows, M, n_rows, a, u);
    else
      surface_product_portable(rows, M, n_rows, a, u);
  }

  void
  rows_product2(const float *rows, const std::size_t M, const std::size_t n_rows, const double *a,
                const double *b, double *u, double *v)
  {
    static const bool avx2 = surface_product_avx2_available();
    if (avx2)
      rows_product2_avx2(rows, M, n_rows, a, b, u, v);
    else
      rows_product2_portable(rows, M, n_rows, a, b, u, v);
  }

  void
  transposed_rows_product(const float *rows, const std::size_t M, const std::size_t n_rows,
                          const double *f, double *g)
  {
    static const bool avx2 = surface_product_avx2_available();
    if (avx2)
      transposed_rows_product_avx2(rows, M, n_rows, f, g);
    else
      transposed_rows_product_portable(rows, M, n_rows, f, g);
  }
} // namespace irdm::detail
