/* What the scheme kernels printed from the numba templates (icidr_pde.native.translate) need
   from C: numpy.dot as kernel_dot_mv / kernel_dot_mm (row-major, as numpy's), and the layouts
   of the driver's Jacobians (the macros the translation addresses J with).

   With ICIDR_BLAS (the build found the OpenBLAS that scikit-sundae ships with its LAPACK
   solver) the products are BLAS dgemv/dgemm, as numpy.dot computes them for numba (faster than
   the plain loops below for the Chebyshev kernels: docs/engines.md). */

#include <stdlib.h>

/* numpy.empty of the printed kernels and its release at the kernel's end: malloc and free, or
   (KERNEL_SCRATCH, the 2-D cell's library) a stack of scratch memory kept between calls, one a
   thread: the 2-D rates allocate the same face arrays at every call, and glibc gave blocks that
   large back to the system at every free (page faults at every call: docs/engines.md).
   A kernel releases all its blocks at its end: the stack is empty again when no block is live; a
   request beyond the stack is malloc'ed, and the stack grown, once empty, to the most used. */
#ifdef KERNEL_SCRATCH
static __thread char *scratch;
static __thread size_t scratch_top, scratch_size, scratch_pending, scratch_wanted;
static __thread long scratch_live;

static void *kernel_empty(size_t bytes)
{
    bytes = (bytes + 63) & ~(size_t)63;
    if (scratch_live == 0 && scratch_wanted > scratch_size) {
        free(scratch);
        scratch = malloc(scratch_wanted);
        scratch_size = scratch ? scratch_wanted : 0;
    }
    scratch_live++;
    scratch_pending += bytes;
    if (scratch_pending > scratch_wanted)
        scratch_wanted = scratch_pending;
    if (scratch_top + bytes > scratch_size)
        return malloc(bytes);
    void *block = scratch + scratch_top;
    scratch_top += bytes;
    return block;
}

static void kernel_free(void *block)
{
    char *b = block;
    if (!(scratch && b >= scratch && b < scratch + scratch_size))
        free(block);
    if (--scratch_live == 0)
        scratch_top = scratch_pending = 0;
}
#else
#define kernel_empty malloc
#define kernel_free free
#endif

/* fd: the compact band jb[col * FD_BAND + row - col + FD_LOWER] of CVODE's interleaved
   ordering (bandwidths 5 and 5) */
#define FD_LOWER 5
#define FD_BAND 11
#define FD_BAND_AT(J, row, col) J[(col) * FD_BAND + (row) - (col) + FD_LOWER]
/* cheb: the dense column-major (3n, 3n) matrix of SUNDIALS */
#define COLUMN_MAJOR_AT(J, row, col) J[(col) * J##_shape0 + (row)]

#ifdef ICIDR_BLAS
enum { CBLAS_ROW_MAJOR = 101, CBLAS_COL_MAJOR = 102, CBLAS_NO_TRANS = 111, CBLAS_TRANS = 112 };
void cblas_dgemv(int order, int trans, int m, int n, double alpha, const double *a, int lda, const double *x,
                 int incx, double beta, double *y, int incy);
void cblas_dgemm(int order, int trans_a, int trans_b, int m, int n, int k, double alpha, const double *a,
                 int lda, const double *b, int ldb, double beta, double *c, int ldc);
void openblas_set_num_threads(int threads);
#endif

/* out (m) = A (m, k) x (k) */
static void kernel_dot_mv(const double *A, long m, long k, const double *x, double *out)
{
#ifdef ICIDR_BLAS
    cblas_dgemv(CBLAS_ROW_MAJOR, CBLAS_NO_TRANS, (int)m, (int)k, 1.0, A, (int)k, x, 1, 0.0, out, 1);
#else
    for (long i = 0; i < m; i++) {
        const double *row = A + i * k;
        double s = 0.0;
        for (long j = 0; j < k; j++)
            s += row[j] * x[j];
        out[i] = s;
    }
#endif
}

/* out (m, p) = A (m, k) B (k, p) */
static void kernel_dot_mm(const double *A, long m, long k, const double *B, long p, double *out)
{
#ifdef ICIDR_BLAS
    cblas_dgemm(CBLAS_ROW_MAJOR, CBLAS_NO_TRANS, CBLAS_NO_TRANS, (int)m, (int)p, (int)k, 1.0, A, (int)k, B,
                (int)p, 0.0, out, (int)p);
#else
    for (long i = 0; i < m; i++) {
        double *row = out + i * p;
        for (long j = 0; j < p; j++)
            row[j] = 0.0;
        for (long q = 0; q < k; q++) {
            double a = A[i * k + q];
            const double *b = B + q * p;
            for (long j = 0; j < p; j++)
                row[j] += a * b[j];
        }
    }
#endif
}
