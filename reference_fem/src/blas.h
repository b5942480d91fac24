// The BLAS and LAPACK routines the modal precompute calls directly (OpenBLAS on Debian: its
// GEMM uses the machine's widest vectors, where Eigen's own product is built for the baseline).
#pragma once

extern "C"
{
  // OpenBLAS's thread control, if the BLAS in use is OpenBLAS (weak: absent elsewhere).
  void
  openblas_set_num_threads(int) __attribute__((weak));
  int
  openblas_get_num_threads() __attribute__((weak));
  void
  dsygvd_(const int *itype, const char *jobz, const char *uplo, const int *n, double *a,
          const int *lda, double *b, const int *ldb, double *w, double *work, const int *lwork,
          int *iwork, const int *liwork, int *info);
  void
  dsyevd_(const char *jobz, const char *uplo, const int *n, double *a, const int *lda, double *w,
          double *work, const int *lwork, int *iwork, const int *liwork, int *info);
  void
  sgemm_(const char *ta, const char *tb, const int *m, const int *n, const int *k,
         const float *alpha, const float *a, const int *lda, const float *b, const int *ldb,
         const float *beta, float *c, const int *ldc);
  void
  dgemm_(const char *ta, const char *tb, const int *m, const int *n, const int *k,
         const double *alpha, const double *a, const int *lda, const double *b, const int *ldb,
         const double *beta, double *c, const int *ldc);
}
