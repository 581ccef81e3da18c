/* CVODE driver of the native engine: the shear cell, finite volumes (fd) or Chebyshev
   collocation (cheb), integrated by SUNDIALS CVODE without a Python callback.

   The same CVODE set-up as icidr_pde.engines.sundae.CvodeEngine (through scikit-sundae) on
   the same problem: BDF up to order 5, scalar tolerances, the band linear solver with
   bandwidths (5, 5) and the analytic band Jacobian (fd_jacobian_interleaved), at most 3 Newton
   iterations and 10 convergence failures a step, 1e6 steps, the minimum step the caller
   gives (a fraction of the fastest time scale 1/rho(J(y0)), icidr_pde.time_scale), and the
   validity root function
   (min phi - lo, hi - max phi, direction -1, terminal). Output at requested times by
   CV_NORMAL calls (CVODE's interpolant): no output time changes CVODE's steps.
   Chebyshev (as CvodeEngine's dense 'analytic' mode): the analytic dense Jacobian
   (cheb_jacobian) and the dense LU, LAPACK's (SUNLinSol_LapackDense, OpenBLAS) where the
   build found it, else SUNDIALS' own; the factored Newton matrix kept until gamma changed
   by delta_gamma (icidr_pde.engines.base.DENSE_LU_DELTA_GAMMA); the state in blocks (phi, u, w).
   Or (icidr_cheb_krylov, where the build found SPGMR and LAPACK): Newton-Krylov, SUNDIALS'
   GMRES (SPGMR, left preconditioning) with CVODE's difference-quotient products J v (one
   right-hand side each, O(N^2)), preconditioned by the LU of I - gamma J_p, J_p the analytic
   dense Jacobian of an earlier step: a preconditioner may be stale where a direct solve's
   matrix may not, so it is refactored only every `setup_steps` steps or when gamma changed
   by delta_gamma, and J_p re-evaluated only when CVODE says it is stale (jok = 0).
   Or (band = 1) preconditioned by I - gamma J_lo, J_lo the Jacobian of the same law with D
   replaced by low-order differences on the same points (cheb_low_order_jacobian), a band
   (5, 5) in the interleaved ordering factored by LAPACK's band LU: O(N) a set-up.
   GMRES leaves a residual, and its mass enters every Newton update (the exact solve of
   (I - gamma J) x = r keeps c . x = c . r, c the Clenshaw-Curtis weights of phi, since c . J = 0):
   so the Krylov path projects each step onto the initial mass (CVODE's projection, CVodeSetProjFn:
   the correction along c and the error estimate onto c's complement), conserving it to round-off
   as the direct solves do.
   The 2-D cell (fv2d, a library of its own, ICIDR_PLANE: the law of plane flow): Newton-Krylov
   as icidr_pde.engines.sundae's 'GMRES' on a thick cell: SUNDIALS' GMRES (SPGMR, its default
   Gram-Schmidt) without a preconditioner, Krylov dimension and tolerance factor (eps_lin) given,
   CVODE's difference-quotient products J v; the state the fields in blocks, (3, nx, nz) row-major.
   Placed after the law (icidr_pde.rheology.ccode), kernel_support.c and the scheme kernels
   printed from the numba templates discretizations/templates/fd.py and cheb.py
   (icidr_pde.native.translate: fd_rates, fd_jacobian_interleaved, cheb_rates, cheb_jacobian) or,
   with ICIDR_PLANE, cartesian2d.py (fv2d_halo_into, fv2d_patch_rates);
   sundials_api.h declares the part of the SUNDIALS C API used here. */

#include <stdlib.h>
#include <string.h>
#include <stdio.h>
#include <time.h>

#define EXPORT __attribute__((visibility("default")))

enum { KIND_FD = 0, KIND_CHEB = 1, KIND_FV2D = 2 };

typedef struct {
    int kind;
    int n;                /* points (fd, cheb) or cells (fv2d: nx nz) */
    double h;
    int nx, nz;           /* fv2d: cells along x (periodic) and z */
    double hx, hz;        /* fv2d: cell widths */
    int upwind;
    double ghost[12];
    double *params;
    int n_params;
    double lo, hi;
    double *work, *jb, *y_good;
    double *D;            /* cheb: differentiation matrix, row-major */
    int lapack;           /* cheb: LAPACK's dense LU (else SUNDIALS' own) */
    double delta_gamma;   /* cheb: refactor when gamma changed by more than this (0: SUNDIALS' 0.3) */
    int krylov;           /* cheb: GMRES preconditioned by a lagged dense LU (icidr_cheb_krylov) */
    int max_krylov;       /* cheb, krylov: Krylov subspace dimension */
    double eps_lin;       /* cheb, krylov: GMRES tolerance factor (CVODE's eplifac) */
    long setup_steps;     /* cheb, krylov: steps between preconditioner set-ups (CVODE's msbp) */
    long jac_steps;       /* cheb, krylov: steps after which J_p is stale (CVODE's msbj) */
    long n_jac;           /* cheb, krylov: analytic Jacobians evaluated for the preconditioner */
    double *Jp, *P;       /* cheb, krylov: J_p and the LU of I - gamma J_p, column-major */
    int *pivots;
    int band;             /* cheb, krylov: the low-order band preconditioner instead of J_p */
    double *z;            /* cheb, band: the collocation points */
    double *x;            /* cheb, band: a vector in the interleaved ordering */
    double *mass_w;       /* cheb, krylov: the quadrature weights of phi (the conserved c . y), or NULL */
    double mass0, mass_ww; /* cheb, krylov: c . y0 and c . c */
    double t_good;
    void *cvode;
    SUNContext ctx;
    N_Vector y;
    SUNMatrix A;
    SUNLinearSolver LS;
    char message[1024];
} Native;

/* where phi and w of point i sit in the state vector: interleaved (fd) or in blocks (cheb, fv2d) */
#define PHI_AT(p, i) ((p)->kind == KIND_FD ? 3 * (i) : (i))
#define W_AT(p, i) ((p)->kind == KIND_FD ? 3 * (i) + 2 : 2 * (p)->n + (i))

/* scratch doubles a problem of n points needs: fd's fields and rates in the templates' layout */
#define FD_WORK(n) (6 * (size_t)(n))
#define CHEB_WORK(n) 1
/* fv2d's patch: the whole grid with its ghost layer, (3, nx + 2, nz + 2) */
#define FV2D_WORK(nx, nz) (3 * ((size_t)(nx) + 2) * ((size_t)(nz) + 2))

/* fd: CVODE's interleaved vector y[3 i + k] (the band ordering) as the template's fields (3, n);
   cheb's vector is in blocks, the fields themselves */
static void fd_fields(int n, const double *y, double *data)
{
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            data[k * n + i] = y[3 * i + k];
}

static void problem_rates(Native *p, const double *y, double *out)
{
#ifdef ICIDR_PLANE
    long nx = p->nx, nz = p->nz;
    fv2d_halo_into((double *)y, 3, nx, nz, p->ghost, 3, 2, 2, p->work, 3, nx + 2, nz + 2);
    fv2d_patch_rates(p->work, 3, nx + 2, nz + 2, p->hx, p->hz, p->upwind, p->params, p->n_params, out, 3, nx, nz);
#else
    int n = p->n;
    if (p->kind == KIND_CHEB) {
        cheb_rates((double *)y, 3, n, p->D, n, n, p->params, p->n_params, out, 3, n);
        return;
    }
    double *data = p->work, *rates = p->work + 3 * n;
    fd_fields(n, y, data);
    fd_rates(data, 3, n, p->ghost, 3, 2, 2, p->h, p->upwind, p->params, p->n_params, rates, 3, n);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            out[3 * i + k] = rates[k * n + i];
#endif
}

/* cheb: the dense column-major Jacobian; fd: the compact band (FD_BAND_AT of kernel_support.c),
   zero outside the entries the template writes */
static void problem_jacobian(Native *p, const double *y, double *J)
{
#ifndef ICIDR_PLANE
    int n = p->n;
    if (p->kind == KIND_CHEB) {
        cheb_jacobian((double *)y, 3, n, p->D, n, n, p->params, p->n_params, J, 3 * n, 3 * n);
        return;
    }
    fd_fields(n, y, p->work);
    memset(J, 0, sizeof(double) * FD_BAND * 3 * (size_t)n);
    fd_jacobian_interleaved(p->work, 3, n, p->ghost, 3, 2, 2, p->h, p->upwind, p->params, p->n_params, J, 3 * n,
                            3 * n);
#endif
}

static int rhs_fn(sunrealtype t, N_Vector y, N_Vector ydot, void *user_data)
{
    problem_rates((Native *)user_data, N_VGetArrayPointer(y), N_VGetArrayPointer(ydot));
    return 0;
}

static int jac_fn(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *user_data,
                  N_Vector tmp1, N_Vector tmp2, N_Vector tmp3)
{
    Native *p = (Native *)user_data;
    int neq = 3 * p->n;
    if (p->kind == KIND_CHEB) {
        problem_jacobian(p, N_VGetArrayPointer(y), SUNDenseMatrix_Data(J));
        return 0;
    }
    problem_jacobian(p, N_VGetArrayPointer(y), p->jb);
    for (int col = 0; col < neq; col++) {
        sunrealtype *column = SUNBandMatrix_Column(J, col);  /* column[row - col] */
        int first = col - FD_LOWER < 0 ? 0 : col - FD_LOWER;
        int last = col + FD_LOWER > neq - 1 ? neq - 1 : col + FD_LOWER;
        for (int row = first; row <= last; row++)
            column[row - col] = p->jb[col * FD_BAND + row - col + FD_LOWER];
    }
    return 0;
}

#if defined(ICIDR_SPGMR) && defined(ICIDR_BLAS) && !defined(ICIDR_PLANE)
#define ICIDR_KRYLOV
void dgetrf_(const int *m, const int *n, double *a, const int *lda, int *ipiv, int *info);
void dgetrs_(const char *trans, const int *n, const int *nrhs, const double *a, const int *lda, const int *ipiv,
             double *b, const int *ldb, int *info);

void dgbtrf_(const int *m, const int *n, const int *kl, const int *ku, double *ab, const int *ldab, int *ipiv,
             int *info);
void dgbtrs_(const char *trans, const int *n, const int *kl, const int *ku, const int *nrhs, const double *ab,
             const int *ldab, const int *ipiv, double *b, const int *ldb, int *info);
#define CHEB_LDAB (3 * FD_LOWER + 1)  /* LAPACK's band storage with room for the LU's fill */

/* the band preconditioner I - gamma J_lo in LAPACK's band storage, factored; J_lo at y unless kept */
static int band_setup(Native *p, const double *y, int jok, int *jcur, double gamma)
{
    int neq = 3 * p->n, kl = FD_LOWER, ldab = CHEB_LDAB, info = 0;
    if (!jok) {
        cheb_low_order_jacobian((double *)y, 3, p->n, p->D, p->n, p->n, p->z, p->n, p->params, p->n_params, p->jb,
                                neq, neq);
        p->n_jac++;
    }
    *jcur = !jok;
    for (int col = 0; col < neq; col++) {
        double *ab = p->P + (size_t)col * CHEB_LDAB;
        for (int k = 0; k < CHEB_LDAB; k++)
            ab[k] = 0.0;
        int first = col - FD_LOWER < 0 ? 0 : col - FD_LOWER;
        int last = col + FD_LOWER > neq - 1 ? neq - 1 : col + FD_LOWER;
        for (int row = first; row <= last; row++)
            ab[2 * FD_LOWER + row - col] = (row == col) - gamma * p->jb[col * FD_BAND + row - col + FD_LOWER];
    }
    dgbtrf_(&neq, &neq, &kl, &kl, p->P, &ldab, p->pivots, &info);
    return info == 0 ? 0 : 1;
}

/* z = (I - gamma J_lo)^-1 r: the blocks (phi, u, w) interleaved, solved, and back */
static int band_solve(Native *p, const double *r, double *z)
{
    int n = p->n, neq = 3 * n, kl = FD_LOWER, ldab = CHEB_LDAB, one = 1, info = 0;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            p->x[3 * i + k] = r[k * n + i];
    dgbtrs_("N", &neq, &kl, &kl, &one, p->P, &ldab, p->pivots, p->x, &neq, &info);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            z[k * n + i] = p->x[3 * i + k];
    return info == 0 ? 0 : -1;
}

/* the preconditioner I - gamma J_p, factored (LAPACK); J_p re-evaluated unless CVODE says it may be kept */
static int prec_setup(sunrealtype t, N_Vector y, N_Vector fy, int jok, int *jcur, sunrealtype gamma,
                      void *user_data)
{
    Native *p = (Native *)user_data;
    int neq = 3 * p->n, info = 0;
    size_t size = (size_t)neq * neq;
    if (p->band)
        return band_setup(p, N_VGetArrayPointer(y), jok, jcur, gamma);
    if (!jok) {
        problem_jacobian(p, N_VGetArrayPointer(y), p->Jp);
        p->n_jac++;
    }
    *jcur = !jok;
    for (size_t k = 0; k < size; k++)
        p->P[k] = -gamma * p->Jp[k];
    for (int i = 0; i < neq; i++)
        p->P[(size_t)i * neq + i] += 1.0;
    dgetrf_(&neq, &neq, p->P, &neq, p->pivots, &info);
    return info == 0 ? 0 : 1;  /* > 0: recoverable, CVODE retries with a fresh J_p or a smaller step */
}

static int prec_solve(sunrealtype t, N_Vector y, N_Vector fy, N_Vector r, N_Vector z, sunrealtype gamma,
                      sunrealtype delta, int lr, void *user_data)
{
    Native *p = (Native *)user_data;
    int neq = 3 * p->n, one = 1, info = 0;
    if (p->band)
        return band_solve(p, N_VGetArrayPointer(r), N_VGetArrayPointer(z));
    memcpy(N_VGetArrayPointer(z), N_VGetArrayPointer(r), sizeof(double) * neq);
    dgetrs_("N", &neq, &one, p->P, &neq, p->pivots, N_VGetArrayPointer(z), &neq, &info);
    return info == 0 ? 0 : -1;
}
#endif

static int root_fn(sunrealtype t, N_Vector y, sunrealtype *gout, void *user_data)
{
    Native *p = (Native *)user_data;
    const double *v = N_VGetArrayPointer(y);
    double low = INFINITY, high = -INFINITY;
    for (int i = 0; i < p->n; i++) {
        double phi = v[PHI_AT(p, i)];
        low = phi < low ? phi : low;   /* as min()/max(): a NaN never wins */
        high = phi > high ? phi : high;
    }
    gout[0] = low - p->lo;
    gout[1] = p->hi - high;
    return 0;
}

static void error_handler(int line, const char *func, const char *file, const char *msg,
                          SUNErrCode err_code, void *err_user_data, SUNContext sunctx)
{
    Native *p = (Native *)err_user_data;
    snprintf(p->message, sizeof p->message, "%s", msg ? msg : "");
}

EXPORT void icidr_free(Native *p);

/* what every problem holds: n points, the law's parameters, the valid range of phi, `work`
   doubles of scratch and the last good state; NULL where memory runs out */
static Native *problem_new(int kind, int n, const double *params, int n_params, double lo, double hi,
                           size_t work)
{
    Native *p = calloc(1, sizeof(Native));
    if (!p)
        return NULL;
    p->kind = kind;
    p->n = n;
    p->lo = lo;
    p->hi = hi;
    p->params = malloc(sizeof(double) * (n_params > 0 ? n_params : 1));
    p->work = malloc(sizeof(double) * work);
    p->y_good = malloc(sizeof(double) * 3 * (size_t)n);
    if (!p->params || !p->work || !p->y_good) {
        icidr_free(p);
        return NULL;
    }
    memcpy(p->params, params, sizeof(double) * n_params);
    p->n_params = n_params;
    return p;
}

/* the problem without CVODE: for the right-hand side, the Jacobian and the time scale alone */
EXPORT Native *icidr_fd_problem(int n, double h, int upwind, const double *ghost, const double *params,
                                int n_params, double lo, double hi)
{
    Native *p = problem_new(KIND_FD, n, params, n_params, lo, hi, FD_WORK(n));
    if (!p)
        return NULL;
    p->h = h;
    p->upwind = upwind;
    memcpy(p->ghost, ghost, sizeof p->ghost);
    p->jb = malloc(sizeof(double) * FD_BAND * 3 * (size_t)n);
    if (!p->jb) {
        icidr_free(p);
        return NULL;
    }
    return p;
}

/* the 2-D cell on nx x nz cells of widths hx, hz (ghost: the walls' maps, (3, 2, 2)), integrated by
   GMRES(max_krylov) without a preconditioner at the tolerance factor eps_lin; NULL where memory runs
   out or the build has no SPGMR */
EXPORT Native *icidr_fv2d_problem(int nx, int nz, double hx, double hz, int upwind, const double *ghost,
                                  const double *params, int n_params, double lo, double hi, int max_krylov,
                                  double eps_lin)
{
#if defined(ICIDR_PLANE) && defined(ICIDR_SPGMR)
    Native *p = problem_new(KIND_FV2D, nx * nz, params, n_params, lo, hi, FV2D_WORK(nx, nz));
    if (!p)
        return NULL;
    p->nx = nx;
    p->nz = nz;
    p->hx = hx;
    p->hz = hz;
    p->upwind = upwind;
    memcpy(p->ghost, ghost, sizeof p->ghost);
    p->krylov = 1;
    p->max_krylov = max_krylov;
    p->eps_lin = eps_lin;
    return p;
#else
    return NULL;
#endif
}

/* the Chebyshev problem on n points: D row-major (n, n); `lapack` chooses the dense LU */
EXPORT Native *icidr_cheb_problem(int n, const double *D, const double *params, int n_params, double lo,
                                  double hi, int lapack, double delta_gamma)
{
    Native *p = problem_new(KIND_CHEB, n, params, n_params, lo, hi, CHEB_WORK(n));
    if (!p)
        return NULL;
    p->lapack = lapack;
    p->delta_gamma = delta_gamma;
    p->D = malloc(sizeof(double) * (size_t)n * n);
    if (!p->D) {
        icidr_free(p);
        return NULL;
    }
    memcpy(p->D, D, sizeof(double) * (size_t)n * n);
    return p;
}

/* 1 where the build has SPGMR and LAPACK (icidr_cheb_krylov can be used), else 0 */
EXPORT int icidr_has_krylov(void)
{
#ifdef ICIDR_KRYLOV
    return 1;
#else
    return 0;
#endif
}

/* cheb: Newton-Krylov instead of the dense LU (see the file's docstring), preconditioned by the
   lagged dense LU or (band, z the points) the low-order band; returns 0 where the build has no SPGMR
   or no LAPACK (the dense LU stays), -1 where memory runs out */
EXPORT int icidr_cheb_krylov(Native *p, int max_krylov, double eps_lin, long setup_steps, long jac_steps, int band,
                             const double *z)
{
#ifdef ICIDR_KRYLOV
    size_t n3 = 3 * (size_t)p->n;
    p->band = band;
    if (band) {
        p->z = malloc(sizeof(double) * p->n);
        p->x = malloc(sizeof(double) * n3);
        p->jb = malloc(sizeof(double) * FD_BAND * n3);
        p->P = malloc(sizeof(double) * CHEB_LDAB * n3);
        if (p->z)
            memcpy(p->z, z, sizeof(double) * p->n);
    } else {
        p->Jp = malloc(sizeof(double) * n3 * n3);
        p->P = malloc(sizeof(double) * n3 * n3);
    }
    p->pivots = malloc(sizeof(int) * n3);
    if (!p->P || !p->pivots || (band ? !p->z || !p->x || !p->jb : !p->Jp))
        return -1;
    p->krylov = 1;
    p->max_krylov = max_krylov;
    p->eps_lin = eps_lin;
    p->setup_steps = setup_steps;
    p->jac_steps = jac_steps;
    return 1;
#else
    return 0;
#endif
}

EXPORT void icidr_rates(Native *p, const double *y, double *out)
{
    problem_rates(p, y, out);
}

/* J: (3n, 3n) column-major */
EXPORT void icidr_cheb_jacobian(Native *p, const double *y, double *J)
{
    problem_jacobian(p, y, J);
}

/* cheb: the band preconditioner's J_lo at y on the points z, compact band (FD_BAND_AT) */
EXPORT void icidr_cheb_low_order_jacobian(Native *p, const double *y, const double *z, double *jb)
{
#if defined(ICIDR_KRYLOV) && !defined(ICIDR_PLANE)
    int neq = 3 * p->n;
    cheb_low_order_jacobian((double *)y, 3, p->n, p->D, p->n, p->n, (double *)z, p->n, p->params, p->n_params, jb,
                            neq, neq);
#endif
}

EXPORT void icidr_fd_jacobian(Native *p, const double *y, double *jb)
{
    problem_jacobian(p, y, jb);
}

static double seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* best of `reps` timings (seconds) of one right-hand side (out[0]) and one Jacobian (out[1]): fd's
   band Jacobian with its copy into a band array, cheb's dense one; the kernels' own cost, for the
   benchmark's roofline */
EXPORT void icidr_kernel_times(Native *p, const double *y, int reps, double *out)
{
    int neq = 3 * p->n;
    size_t jac_size = p->kind == KIND_CHEB ? (size_t)neq * neq : FD_BAND * (size_t)neq;
    double *f = malloc(sizeof(double) * neq), *J = malloc(sizeof(double) * jac_size);
    out[0] = out[1] = INFINITY;
    for (int r = 0; r < reps; r++) {
        double start = seconds();
        problem_rates(p, y, f);
        double mid = seconds();
        if (p->kind == KIND_FV2D) {
            out[1] = 0.0;  /* no Jacobian: CVODE's products J v */
        } else if (p->kind == KIND_CHEB) {
            problem_jacobian(p, y, J);
        } else {
            problem_jacobian(p, y, p->jb);
            memcpy(J, p->jb, sizeof(double) * jac_size);
        }
        double end = seconds();
        out[0] = mid - start < out[0] ? mid - start : out[0];
        out[1] = end - mid < out[1] ? end - mid : out[1];
    }
    free(f);
    free(J);
}

/* OpenBLAS threads of the dense LU and the BLAS products (returns 0 where the build has no BLAS) */
EXPORT int icidr_blas_threads(int threads)
{
#ifdef ICIDR_BLAS
    openblas_set_num_threads(threads);
    return 1;
#else
    return 0;
#endif
}

/* M(phi) of the law at m points (for chi of (A18)) */
EXPORT void icidr_law_M(Native *p, int m, const double *phi, double *out)
{
    for (int k = 0; k < m; k++)
        out[k] = law_M(phi[k], p->params);
}

#define CHECK(call) do { if ((call) < 0) { snprintf(error, error_len, "%s failed", #call); goto fail; } } while (0)

/* Start CVODE at (t0, y0) on the problem `p`; 0 on success, else -1 with `error` set. */
/* cheb, krylov: the least correction along c that restores c . y = c . y0, and the error estimate
   without its component along c (CVODE's projection interface) */
static int project_mass(sunrealtype t, N_Vector ycur, N_Vector corr, sunrealtype eps, N_Vector err, void *data)
{
    Native *p = data;
    const double *y = N_VGetArrayPointer(ycur);
    double *c = N_VGetArrayPointer(corr), defect = p->mass0;
    int n = p->n;
    for (int i = 0; i < n; i++)
        defect -= p->mass_w[i] * y[i];
    memset(c, 0, sizeof(double) * 3 * (size_t)n);
    for (int i = 0; i < n; i++)
        c[i] = defect * p->mass_w[i] / p->mass_ww;
    if (err) {
        double *e = N_VGetArrayPointer(err), along = 0.0;
        for (int i = 0; i < n; i++)
            along += p->mass_w[i] * e[i];
        for (int i = 0; i < n; i++)
            e[i] -= along * p->mass_w[i] / p->mass_ww;
    }
    return 0;
}

/* cheb, krylov: conserve c . y, c = (w, 0, 0) with the quadrature weights w of phi (n of them),
   by projecting every step (see the file's docstring); returns -1 where memory runs out */
EXPORT int icidr_cheb_conserve(Native *p, const double *w)
{
    free(p->mass_w);
    p->mass_w = malloc(sizeof(double) * p->n);
    if (!p->mass_w)
        return -1;
    memcpy(p->mass_w, w, sizeof(double) * p->n);
    p->mass_ww = 0.0;
    for (int i = 0; i < p->n; i++)
        p->mass_ww += w[i] * w[i];
    return 0;
}

EXPORT int icidr_cvode_start(Native *p, double t0, const double *y0, double rtol, double atol,
                             double min_step, double max_step, long max_num_steps, double first_step,
                             int max_order, char *error, int error_len)
{
    int neq = 3 * p->n;
    int direction[2] = {-1, -1};
    if (SUNContext_Create(SUN_COMM_NULL, &p->ctx) < 0) {
        snprintf(error, error_len, "SUNContext_Create failed");
        return -1;
    }
    SUNContext_ClearErrHandlers(p->ctx);
    SUNContext_PushErrHandler(p->ctx, error_handler, p);
    p->y = N_VNew_Serial(neq, p->ctx);
    if (!p->y) {
        snprintf(error, error_len, "N_VNew_Serial failed");
        goto fail;
    }
    memcpy(N_VGetArrayPointer(p->y), y0, sizeof(double) * neq);
    memcpy(p->y_good, y0, sizeof(double) * neq);
    p->t_good = t0;
    p->cvode = CVodeCreate(CV_BDF, p->ctx);
    if (!p->cvode) {
        snprintf(error, error_len, "CVodeCreate failed");
        goto fail;
    }
    CHECK(CVodeSetUserData(p->cvode, p));
    CHECK(CVodeInit(p->cvode, rhs_fn, t0, p->y));
    CHECK(CVodeSStolerances(p->cvode, rtol, atol));
    if (p->kind == KIND_FV2D) {
#ifdef ICIDR_SPGMR
        p->LS = SUNLinSol_SPGMR(p->y, SUN_PREC_NONE, p->max_krylov, p->ctx);
        if (!p->LS) {
            snprintf(error, error_len, "SPGMR not created");
            goto fail;
        }
        CHECK(CVodeSetLinearSolver(p->cvode, p->LS, NULL));
        CHECK(CVodeSetEpsLin(p->cvode, p->eps_lin));
#endif
    } else if (p->kind == KIND_CHEB && p->krylov) {
#ifdef ICIDR_KRYLOV
        p->LS = SUNLinSol_SPGMR(p->y, SUN_PREC_LEFT, p->max_krylov, p->ctx);
        if (!p->LS) {
            snprintf(error, error_len, "SPGMR not created");
            goto fail;
        }
        CHECK(SUNLinSol_SPGMRSetGSType(p->LS, SUN_CLASSICAL_GS));
        CHECK(CVodeSetLinearSolver(p->cvode, p->LS, NULL));
        CHECK(CVodeSetPreconditioner(p->cvode, prec_setup, prec_solve));
        CHECK(CVodeSetEpsLin(p->cvode, p->eps_lin));
        CHECK(CVodeSetLSetupFrequency(p->cvode, p->setup_steps));
        CHECK(CVodeSetJacEvalFrequency(p->cvode, p->jac_steps));
        if (p->mass_w) {
            p->mass0 = 0.0;
            for (int i = 0; i < p->n; i++)
                p->mass0 += p->mass_w[i] * y0[i];
            CHECK(CVodeSetProjFn(p->cvode, project_mass));
        }
#endif
    } else if (p->kind == KIND_CHEB) {
        p->A = SUNDenseMatrix(neq, neq, p->ctx);
#ifdef ICIDR_LAPACK_DENSE
        p->LS = p->A ? (p->lapack ? SUNLinSol_LapackDense(p->y, p->A, p->ctx) : SUNLinSol_Dense(p->y, p->A, p->ctx))
                     : NULL;
#else
        p->LS = p->A ? SUNLinSol_Dense(p->y, p->A, p->ctx) : NULL;
#endif
    } else {
        p->A = SUNBandMatrix(neq, FD_LOWER, FD_LOWER, p->ctx);
        p->LS = p->A ? SUNLinSol_Band(p->y, p->A, p->ctx) : NULL;
    }
    if (!p->krylov) {
        if (!p->A || !p->LS) {
            snprintf(error, error_len, "matrix or linear solver not created");
            goto fail;
        }
        CHECK(CVodeSetLinearSolver(p->cvode, p->LS, p->A));
        CHECK(CVodeSetJacFn(p->cvode, jac_fn));
    }
    if (p->kind == KIND_CHEB && p->delta_gamma > 0)
        CHECK(CVodeSetDeltaGammaMaxLSetup(p->cvode, p->delta_gamma));
    CHECK(CVodeSetMaxNonlinIters(p->cvode, 3));
    CHECK(CVodeSetMaxConvFails(p->cvode, 10));
    CHECK(CVodeRootInit(p->cvode, 2, root_fn));
    CHECK(CVodeSetRootDirection(p->cvode, direction));
    CHECK(CVodeSetInitStep(p->cvode, first_step));
    CHECK(CVodeSetMinStep(p->cvode, min_step));
    CHECK(CVodeSetMaxStep(p->cvode, max_step));
    CHECK(CVodeSetMaxOrd(p->cvode, max_order));
    CHECK(CVodeSetMaxNumSteps(p->cvode, max_num_steps));
    /* no "t + h = t" warnings on stdout (they would break --json /dev/stdout): a step that small
       ends the run at the minimum step, whose reason the Result reports */
    CHECK(CVodeSetMaxHnilWarns(p->cvode, -1));
    return 0;
fail:
    if (p->message[0]) {
        int used = (int)strlen(error);
        snprintf(error + used, error_len - used, ": %s", p->message);
    }
    return -1;
}

static int inside(const Native *p, const double *v)
{
    for (int k = 0; k < 3 * p->n; k++)
        if (!isfinite(v[k]))
            return 0;
    for (int i = 0; i < p->n; i++)
        if (!(p->lo < v[PHI_AT(p, i)] && v[PHI_AT(p, i)] < p->hi))
            return 0;
    return 1;
}

/* Advance through the output times t_out[0..n_out-1] (increasing, after the current time).
   At each: max_w[k] = max |w| over the cells, and the state into states + store[k] * 3n where
   store[k] >= 0. Returns 0 when all are done, else the output index k where it stopped
   (*n_done = k) and *status: 1 a root (phi reached the end of its range), 2 CVODE failed
   (flag in *flag, message via icidr_cvode_message), 3 the state at t_out[k] is invalid.
   The last valid state and its time are kept (icidr_cvode_last_good). */
EXPORT int icidr_cvode_advance(Native *p, int n_out, const double *t_out, const int *store, double *max_w,
                               double *states, int *n_done, int *status, int *flag)
{
    int neq = 3 * p->n;
    double *y = N_VGetArrayPointer(p->y);
    *status = 0;
    *flag = 0;
    for (int k = 0; k < n_out; k++) {
        double t_ret = p->t_good;
        p->message[0] = 0;
        int f = CVode(p->cvode, t_out[k], p->y, &t_ret, CV_NORMAL);
        *flag = f;
        int finite = 1;
        for (int q = 0; q < neq; q++)
            finite &= isfinite(y[q]) != 0;
        if (f < 0) {
            if (finite && t_ret > p->t_good) {
                p->t_good = t_ret;
                memcpy(p->y_good, y, sizeof(double) * neq);
            }
            *n_done = k;
            *status = 2;
            return 1;
        }
        p->t_good = t_ret;
        memcpy(p->y_good, y, sizeof(double) * neq);
        if (f == CV_ROOT_RETURN) {
            *n_done = k;
            *status = 1;
            return 1;
        }
        if (!inside(p, y)) {
            *n_done = k;
            *status = 3;
            return 1;
        }
        double m = 0.0;
        for (int i = 0; i < p->n; i++) {
            double a = fabs(y[W_AT(p, i)]);
            m = a > m ? a : m;
        }
        max_w[k] = m;
        if (store[k] >= 0)
            memcpy(states + (size_t)store[k] * neq, y, sizeof(double) * neq);
    }
    *n_done = n_out;
    return 0;
}

EXPORT double icidr_cvode_last_good(Native *p, double *y)
{
    memcpy(y, p->y_good, sizeof(double) * 3 * p->n);
    return p->t_good;
}

EXPORT void icidr_cvode_message(Native *p, int flag, char *out, int out_len)
{
    char *name = CVodeGetReturnFlagName(flag);
    snprintf(out, out_len, "%s%s%s", name ? name : "CVODE error", p->message[0] ? "; SUNDIALS: " : "", p->message);
    free(name);
}

/* steps, RHS evaluations (CVODE's), Jacobians, LU set-ups, error-test
   failures, Newton iterations, Newton convergence failures */
EXPORT void icidr_cvode_counts(Native *p, long *out)
{
    long v = 0;
    memset(out, 0, 7 * sizeof(long));
    if (!p->cvode)
        return;
    CVodeGetNumSteps(p->cvode, &v); out[0] = v;
    CVodeGetNumRhsEvals(p->cvode, &v); out[1] = v;
    CVodeGetNumJacEvals(p->cvode, &v); out[2] = v;
    CVodeGetNumLinSolvSetups(p->cvode, &v); out[3] = v;
    CVodeGetNumErrTestFails(p->cvode, &v); out[4] = v;
    CVodeGetNumNonlinSolvIters(p->cvode, &v); out[5] = v;
    CVodeGetNumNonlinSolvConvFails(p->cvode, &v); out[6] = v;
    if (p->krylov)
        out[2] = p->n_jac;
}

/* cheb, krylov: GMRES iterations, their convergence failures, preconditioner set-ups (LUs) and
   solves, products J v, right-hand sides of those products (not in icidr_cvode_counts' count) */
EXPORT void icidr_krylov_counts(Native *p, long *out)
{
    long v = 0;
    memset(out, 0, 6 * sizeof(long));
    if (!p->cvode || !p->krylov)
        return;
    CVodeGetNumLinIters(p->cvode, &v); out[0] = v;
    CVodeGetNumLinConvFails(p->cvode, &v); out[1] = v;
    CVodeGetNumPrecEvals(p->cvode, &v); out[2] = v;
    CVodeGetNumPrecSolves(p->cvode, &v); out[3] = v;
    CVodeGetNumJtimesEvals(p->cvode, &v); out[4] = v;
    CVodeGetNumLinRhsEvals(p->cvode, &v); out[5] = v;
}

EXPORT void icidr_free(Native *p)
{
    if (!p)
        return;
    if (p->cvode)
        CVodeFree(&p->cvode);
    if (p->LS)
        SUNLinSolFree(p->LS);
    if (p->A)
        SUNMatDestroy(p->A);
    if (p->y)
        N_VDestroy(p->y);
    if (p->ctx)
        SUNContext_Free(&p->ctx);
    free(p->params); free(p->work); free(p->jb); free(p->y_good); free(p->D);
    free(p->Jp); free(p->P); free(p->pivots); free(p->z); free(p->x); free(p->mass_w);
    free(p);
}
