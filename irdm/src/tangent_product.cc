#include "tangent_product.h"

#include "surface_product.h" // surface_product_avx2_available

#include <algorithm>

#if defined(__x86_64__) && defined(__GNUC__)
#  include <immintrin.h>
#  define IRDM_HAVE_AVX2_KERNEL 1
#endif

namespace irdm::detail
{
  namespace
  {
    // U^T (K U) a chunk of rows at a time, so that the chunk's rows of B a tile column reads
    // stay in L1 while the tiles down that column use them.
    constexpr std::size_t row_chunk = 128;
  } // namespace

  // Row by row, each block's column of U added in times its entry (loops the compiler
  // vectorizes).
  void
  block_rows_product_portable(const BlockRows &K, const float *rows, const std::size_t M,
                              float *out)
  {
    std::fill(out, out + 3 * K.n_block_rows * M, 0.0f);
    for (std::size_t i = 0; i < K.n_block_rows; ++i)
      for (unsigned s = K.row_start[i]; s < K.row_start[i + 1]; ++s)
        for (std::size_t b = 0; b < 3; ++b)
          {
            const float *u = rows + (3 * std::size_t(K.column[s]) + b) * M;
            for (std::size_t a = 0; a < 3; ++a)
              {
                const auto k = static_cast<float>(K.blocks[9 * std::size_t(s) + a + 3 * b]);
                float     *o = out + (3 * i + a) * M;
                for (std::size_t m = 0; m < M; ++m)
                  o[m] += k * u[m];
              }
          }
  }

  // Row i of the lower triangle stays in L1 while a chunk of rows k adds a times B's row into
  // it (a loop the compiler vectorizes).
  void
  lower_transposed_product_portable(const float *A, const float *B, const std::size_t n_rows,
                                    const std::size_t M, float *lower)
  {
    for (std::size_t k0 = 0; k0 < n_rows; k0 += row_chunk)
      {
        const std::size_t k1 = std::min(n_rows, k0 + row_chunk);
        for (std::size_t i = 0; i < M; ++i)
          {
            float *l = lower + i * M;
            for (std::size_t k = k0; k < k1; ++k)
              {
                const float  a = A[k * M + i];
                const float *b = B + k * M;
                for (std::size_t j = 0; j <= i; ++j)
                  l[j] += a * b[j];
              }
          }
      }
  }

#ifdef IRDM_HAVE_AVX2_KERNEL
  namespace
  {
    // The lanes of a vector starting at m that lie before M.
    __attribute__((target("avx2,fma"))) inline __m256i
    lanes_before(const std::size_t m, const std::size_t M)
    {
      const auto left = static_cast<int>(std::min<std::size_t>(M - std::min(m, M), 8));
      return _mm256_cmpgt_epi32(_mm256_set1_epi32(left), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    }

    // 32 columns of block row i's three rows of K U: twelve accumulators, each block's nine
    // entries broadcast once per 32 columns and each loaded vector of U used three times.
    template <bool tail>
    __attribute__((target("avx2,fma"))) inline void
    block_row_columns(const BlockRows &K, const std::size_t i, const float *rows,
                      const std::size_t M, const std::size_t m0, const __m256i (&mask)[4],
                      float *out)
    {
      __m256 acc[3][4];
      for (auto &row : acc)
        for (auto &v : row)
          v = _mm256_setzero_ps();
      for (unsigned s = K.row_start[i]; s < K.row_start[i + 1]; ++s)
        {
          const double *blk = K.blocks + 9 * std::size_t(s);
          for (std::size_t b = 0; b < 3; ++b)
            {
              const float *u = rows + (3 * std::size_t(K.column[s]) + b) * M + m0;
              __m256       uv[4];
              for (int v = 0; v < 4; ++v)
                uv[v] = tail ? _mm256_maskload_ps(u + 8 * v, mask[v]) : _mm256_loadu_ps(u + 8 * v);
              for (std::size_t a = 0; a < 3; ++a)
                {
                  const __m256 k = _mm256_set1_ps(static_cast<float>(blk[a + 3 * b]));
                  for (int v = 0; v < 4; ++v)
                    acc[a][v] = _mm256_fmadd_ps(k, uv[v], acc[a][v]);
                }
            }
        }
      for (std::size_t a = 0; a < 3; ++a)
        {
          float *o = out + (3 * i + a) * M + m0;
          for (int v = 0; v < 4; ++v)
            if (tail)
              _mm256_maskstore_ps(o + 8 * v, mask[v], acc[a][v]);
            else
              _mm256_storeu_ps(o + 8 * v, acc[a][v]);
        }
    }

    // A tile of ni rows (i0 ..) by 16 columns (j0 ..) of A^T B over rows k0 .. k1: 2 ni
    // accumulators (twelve at ni = 6, enough independent FMA chains to fill both units), each
    // row's two loaded vectors of B used ni times.
    template <int ni, bool tail>
    __attribute__((target("avx2,fma"))) inline void
    lower_tile(const float *A, const float *B, const std::size_t k0, const std::size_t k1,
               const std::size_t M, const std::size_t i0, const std::size_t j0,
               const __m256i (&mask)[2], float *lower)
    {
      __m256 acc[ni][2];
      for (auto &row : acc)
        row[0] = _mm256_setzero_ps(), row[1] = _mm256_setzero_ps();
      for (std::size_t k = k0; k < k1; ++k)
        {
          const float *b  = B + k * M + j0;
          const __m256 b0 = tail ? _mm256_maskload_ps(b, mask[0]) : _mm256_loadu_ps(b);
          const __m256 b1 = tail ? _mm256_maskload_ps(b + 8, mask[1]) : _mm256_loadu_ps(b + 8);
          const float *a  = A + k * M + i0;
          for (int r = 0; r < ni; ++r)
            {
              const __m256 ar = _mm256_broadcast_ss(a + r);
              acc[r][0]       = _mm256_fmadd_ps(ar, b0, acc[r][0]);
              acc[r][1]       = _mm256_fmadd_ps(ar, b1, acc[r][1]);
            }
        }
      for (int r = 0; r < ni; ++r)
        {
          float *l = lower + (i0 + std::size_t(r)) * M + j0;
          if (tail)
            {
              _mm256_maskstore_ps(l, mask[0], _mm256_add_ps(_mm256_maskload_ps(l, mask[0]), acc[r][0]));
              _mm256_maskstore_ps(l + 8, mask[1], _mm256_add_ps(_mm256_maskload_ps(l + 8, mask[1]), acc[r][1]));
            }
          else
            {
              _mm256_storeu_ps(l, _mm256_add_ps(_mm256_loadu_ps(l), acc[r][0]));
              _mm256_storeu_ps(l + 8, _mm256_add_ps(_mm256_loadu_ps(l + 8), acc[r][1]));
            }
        }
    }

    template <bool tail>
    __attribute__((target("avx2,fma"))) inline void
    lower_tile_rows(const int ni, const float *A, const float *B, const std::size_t k0,
                    const std::size_t k1, const std::size_t M, const std::size_t i0,
                    const std::size_t j0, const __m256i (&mask)[2], float *lower)
    {
      switch (ni)
        {
          case 6: lower_tile<6, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
          case 5: lower_tile<5, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
          case 4: lower_tile<4, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
          case 3: lower_tile<3, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
          case 2: lower_tile<2, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
          default: lower_tile<1, tail>(A, B, k0, k1, M, i0, j0, mask, lower); break;
        }
    }
  } // namespace

  __attribute__((target("avx2,fma"))) void
  block_rows_product_avx2(const BlockRows &K, const float *rows, const std::size_t M, float *out)
  {
    const std::size_t M32 = M - M % 32;
    __m256i           full[4], tail[4];
    for (int v = 0; v < 4; ++v)
      full[v] = _mm256_set1_epi32(-1), tail[v] = lanes_before(M32 + 8 * std::size_t(v), M);
    for (std::size_t i = 0; i < K.n_block_rows; ++i)
      {
        for (std::size_t m0 = 0; m0 < M32; m0 += 32)
          block_row_columns<false>(K, i, rows, M, m0, full, out);
        if (M32 < M) // the last M % 32 columns, masked: no load or store passes a row's end
          block_row_columns<true>(K, i, rows, M, M32, tail, out);
      }
  }

  __attribute__((target("avx2,fma"))) void
  lower_transposed_product_avx2(const float *A, const float *B, const std::size_t n_rows,
                                const std::size_t M, float *lower)
  {
    constexpr std::size_t tile_rows = 6, tile_columns = 16;
    for (std::size_t k0 = 0; k0 < n_rows; k0 += row_chunk)
      {
        const std::size_t k1 = std::min(n_rows, k0 + row_chunk);
        for (std::size_t j0 = 0; j0 < M; j0 += tile_columns)
          {
            const bool    tail    = j0 + tile_columns > M;
            const __m256i mask[2] = {lanes_before(j0, M), lanes_before(j0 + 8, M)};
            // The tiles of this column that reach the lower triangle (some j <= i).
            for (std::size_t i0 = j0 / tile_rows * tile_rows; i0 < M; i0 += tile_rows)
              {
                const int ni = static_cast<int>(std::min(tile_rows, M - i0));
                if (tail)
                  lower_tile_rows<true>(ni, A, B, k0, k1, M, i0, j0, mask, lower);
                else
                  lower_tile_rows<false>(ni, A, B, k0, k1, M, i0, j0, mask, lower);
              }
          }
      }
  }
#else
  void
  block_rows_product_avx2(const BlockRows &K, const float *rows, const std::size_t M, float *out)
  {
    block_rows_product_portable(K, rows, M, out);
  }

  void
  lower_transposed_product_avx2(const float *A, const float *B, const std::size_t n_rows,
                                const std::size_t M, float *lower)
  {
    lower_transposed_product_portable(A, B, n_rows, M, lower);
  }
#endif

  void
  block_rows_product(const BlockRows &K, const float *rows, const std::size_t M, float *out)
  {
    static const bool avx2 = surface_product_avx2_available(); // thread-safe, decided once
    if (avx2)
      block_rows_product_avx2(K, rows, M, out);
    else
      block_rows_product_portable(K, rows, M, out);
  }

  void
  lower_transposed_product(const float *A, const float *B, const std::size_t n_rows,
                           const std::size_t M, float *lower)
  {
    static const bool avx2 = surface_product_avx2_available();
    if (avx2)
      lower_transposed_product_avx2(A, B, n_rows, M, lower);
    else
      lower_transposed_product_portable(A, B, n_rows, M, lower);
  }
} // namespace irdm::detail
