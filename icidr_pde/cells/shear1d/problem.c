/* The compiled problems of the 1-D shear cell, finite volumes (fd) or Chebyshev collocation (cheb),
   for the CVODE driver (icidr_pde/native/cvode_driver.c, which integrates them; problem.h says what
   a problem is to it).

   fd: the same CVODE set-up as icidr_pde.engines.sundae.CvodeEngine (through scikit-sundae) on
   the same problem: the band linear solver with bandwidths (5, 5) and the analytic band Jacobian
   (fd_jacobian_interleaved); the state interleaved, y[3 i + k] (the band ordering).
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
   Placed after the law (icidr_pde.rheology.ccode), kernel_support.c and the scheme kernels
   printed from the numba templates templates/fd.py and cheb.py (icidr_pde.native.translate:
   fd_rates, fd_jacobian_interleaved, cheb_rates, cheb_jacobian, cheb_low_order_jacobian). */

enum { KIND_FD = 0, KIND_CHEB = 1 };

typedef struct {
    int kind;
    double h;
    int upwind;
    double ghost[12];
    double *work, *jb;
    double *D;            /* cheb: differentiation matrix, row-major */
    int lapack;           /* cheb: LAPACK's dense LU (else SUNDIALS' own) */
    double delta_gamma;   /* cheb: refactor when gamma changed by more than this (0: SUNDIALS' 0.3) */
    int max_krylov;       /* cheb, krylov: Krylov subspace dimension */
    double eps_lin;       /* cheb, krylov: GMRES tolerance factor (CVODE's eplifac) */
    long setup_steps;     /* cheb, krylov: steps between preconditioner set-ups (CVODE's msbp) */
    long jac_steps;       /* cheb, krylov: steps after which J_p is stale (CVODE's msbj) */
    double *Jp, *P;       /* cheb, krylov: J_p and the LU of I - gamma J_p, column-major */
    int *pivots;
    int band;             /* cheb, krylov: the low-order band preconditioner instead of J_p */
    double *z;            /* cheb, band: the collocation points */
    double *x;            /* cheb, band: a vector in the interleaved ordering */
    double *mass_w;       /* cheb, krylov: the quadrature weights of phi (the conserved c . y), or NULL */
    double mass0, mass_ww; /* cheb, krylov: c . y0 and c . c */
} Shear;

#define SHEAR(p) ((Shear *)(p)->data)

/* fd: CVODE's interleaved vector y[3 i + k] (the band ordering) as the template's fields (3, n);
   cheb's vector is in blocks, the fields themselves */
static void fd_fields(int n, const double *y, double *data)
{
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            data[k * n + i] = y[3 * i + k];
}

static void shear_rates(Native *p, const double *y, double *out)
{
    Shear *s = SHEAR(p);
    int n = p->n;
    if (s->kind == KIND_CHEB) {
        cheb_rates((double *)y, 3, n, s->D, n, n, p->params, p->n_params, out, 3, n);
        return;
    }
    double *data = s->work, *rates = s->work + 3 * n;
    fd_fields(n, y, data);
    fd_rates(data, 3, n, s->ghost, 3, 2, 2, s->h, s->upwind, p->params, p->n_params, rates, 3, n);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            out[3 * i + k] = rates[k * n + i];
}

/* cheb: the dense column-major Jacobian; fd: the compact band (FD_BAND_AT of kernel_support.c),
   zero outside the entries the template writes */
static void shear_jacobian(Native *p, const double *y, double *J)
{
    Shear *s = SHEAR(p);
    int n = p->n;
    if (s->kind == KIND_CHEB) {
        cheb_jacobian((double *)y, 3, n, s->D, n, n, p->params, p->n_params, J, 3 * n, 3 * n);
        return;
    }
    fd_fields(n, y, s->work);
    memset(J, 0, sizeof(double) * FD_BAND * 3 * (size_t)n);
    fd_jacobian_interleaved(s->work, 3, n, s->ghost, 3, 2, 2, s->h, s->upwind, p->params, p->n_params, J, 3 * n,
                            3 * n);
}

/* fd's timed Jacobian: the band, with its copy into a band array (as CVODE's band matrix takes it) */
static void fd_timed_jacobian(Native *p, const double *y, double *J)
{
    shear_jacobian(p, y, SHEAR(p)->jb);
    memcpy(J, SHEAR(p)->jb, sizeof(double) * p->jacobian_size);
}

static int jac_fn(sunrealtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *user_data,
                  N_Vector tmp1, N_Vector tmp2, N_Vector tmp3)
{
    Native *p = (Native *)user_data;
    Shear *s = SHEAR(p);
    int neq = 3 * p->n;
    if (s->kind == KIND_CHEB) {
        shear_jacobian(p, N_VGetArrayPointer(y), SUNDenseMatrix_Data(J));
        return 0;
    }
    shear_jacobian(p, N_VGetArrayPointer(y), s->jb);
    for (int col = 0; col < neq; col++) {
        sunrealtype *column = SUNBandMatrix_Column(J, col);  /* column[row - col] */
        int first = col - FD_LOWER < 0 ? 0 : col - FD_LOWER;
        int last = col + FD_LOWER > neq - 1 ? neq - 1 : col + FD_LOWER;
        for (int row = first; row <= last; row++)
            column[row - col] = s->jb[col * FD_BAND + row - col + FD_LOWER];
    }
    return 0;
}

#if defined(ICIDR_SPGMR) && defined(ICIDR_BLAS)
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
    Shear *s = SHEAR(p);
    int neq = 3 * p->n, kl = FD_LOWER, ldab = CHEB_LDAB, info = 0;
    if (!jok) {
        cheb_low_order_jacobian((double *)y, 3, p->n, s->D, p->n, p->n, s->z, p->n, p->params, p->n_params, s->jb,
                                neq, neq);
        p->n_jac++;
    }
    *jcur = !jok;
    for (int col = 0; col < neq; col++) {
        double *ab = s->P + (size_t)col * CHEB_LDAB;
        for (int k = 0; k < CHEB_LDAB; k++)
            ab[k] = 0.0;
        int first = col - FD_LOWER < 0 ? 0 : col - FD_LOWER;
        int last = col + FD_LOWER > neq - 1 ? neq - 1 : col + FD_LOWER;
        for (int row = first; row <= last; row++)
            ab[2 * FD_LOWER + row - col] = (row == col) - gamma * s->jb[col * FD_BAND + row - col + FD_LOWER];
    }
    dgbtrf_(&neq, &neq, &kl, &kl, s->P, &ldab, s->pivots, &info);
    return info == 0 ? 0 : 1;
}

/* z = (I - gamma J_lo)^-1 r: the blocks (phi, u, w) interleaved, solved, and back */
static int band_solve(Native *p, const double *r, double *z)
{
    Shear *s = SHEAR(p);
    int n = p->n, neq = 3 * n, kl = FD_LOWER, ldab = CHEB_LDAB, one = 1, info = 0;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            s->x[3 * i + k] = r[k * n + i];
    dgbtrs_("N", &neq, &kl, &kl, &one, s->P, &ldab, s->pivots, s->x, &neq, &info);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            z[k * n + i] = s->x[3 * i + k];
    return info == 0 ? 0 : -1;
}

/* the preconditioner I - gamma J_p, factored (LAPACK); J_p re-evaluated unless CVODE says it may be kept */
static int prec_setup(sunrealtype t, N_Vector y, N_Vector fy, int jok, int *jcur, sunrealtype gamma,
                      void *user_data)
{
    Native *p = (Native *)user_data;
    Shear *s = SHEAR(p);
    int neq = 3 * p->n, info = 0;
    size_t size = (size_t)neq * neq;
    if (s->band)
        return band_setup(p, N_VGetArrayPointer(y), jok, jcur, gamma);
    if (!jok) {
        shear_jacobian(p, N_VGetArrayPointer(y), s->Jp);
        p->n_jac++;
    }
    *jcur = !jok;
    for (size_t k = 0; k < size; k++)
        s->P[k] = -gamma * s->Jp[k];
    for (int i = 0; i < neq; i++)
        s->P[(size_t)i * neq + i] += 1.0;
    dgetrf_(&neq, &neq, s->P, &neq, s->pivots, &info);
    return info == 0 ? 0 : 1;  /* > 0: recoverable, CVODE retries with a fresh J_p or a smaller step */
}

static int prec_solve(sunrealtype t, N_Vector y, N_Vector fy, N_Vector r, N_Vector z, sunrealtype gamma,
                      sunrealtype delta, int lr, void *user_data)
{
    Native *p = (Native *)user_data;
    Shear *s = SHEAR(p);
    int neq = 3 * p->n, one = 1, info = 0;
    if (s->band)
        return band_solve(p, N_VGetArrayPointer(r), N_VGetArrayPointer(z));
    memcpy(N_VGetArrayPointer(z), N_VGetArrayPointer(r), sizeof(double) * neq);
    dgetrs_("N", &neq, &one, s->P, &neq, s->pivots, N_VGetArrayPointer(z), &neq, &info);
    return info == 0 ? 0 : -1;
}
#endif

/* cheb, krylov: the least correction along c that restores c . y = c . y0, and the error estimate
   without its component along c (CVODE's projection interface) */
static int project_mass(sunrealtype t, N_Vector ycur, N_Vector corr, sunrealtype eps, N_Vector err, void *data)
{
    Native *p = data;
    Shear *s = SHEAR(p);
    const double *y = N_VGetArrayPointer(ycur);
    double *c = N_VGetArrayPointer(corr), defect = s->mass0;
    int n = p->n;
    for (int i = 0; i < n; i++)
        defect -= s->mass_w[i] * y[i];
    memset(c, 0, sizeof(double) * 3 * (size_t)n);
    for (int i = 0; i < n; i++)
        c[i] = defect * s->mass_w[i] / s->mass_ww;
    if (err) {
        double *e = N_VGetArrayPointer(err), along = 0.0;
        for (int i = 0; i < n; i++)
            along += s->mass_w[i] * e[i];
        for (int i = 0; i < n; i++)
            e[i] -= along * s->mass_w[i] / s->mass_ww;
    }
    return 0;
}

/* CVODE's linear solver: fd the band LU, cheb the dense LU or (krylov) GMRES with its preconditioner */
static int shear_linear_solver(Native *p, const double *y0, char *error, int error_len)
{
    Shear *s = SHEAR(p);
    int neq = 3 * p->n;
    if (s->kind == KIND_CHEB && p->krylov) {
#ifdef ICIDR_KRYLOV
        p->LS = SUNLinSol_SPGMR(p->y, SUN_PREC_LEFT, s->max_krylov, p->ctx);
        if (!p->LS) {
            snprintf(error, error_len, "SPGMR not created");
            return -1;
        }
        SETUP(SUNLinSol_SPGMRSetGSType(p->LS, SUN_CLASSICAL_GS));
        SETUP(CVodeSetLinearSolver(p->cvode, p->LS, NULL));
        SETUP(CVodeSetPreconditioner(p->cvode, prec_setup, prec_solve));
        SETUP(CVodeSetEpsLin(p->cvode, s->eps_lin));
        SETUP(CVodeSetLSetupFrequency(p->cvode, s->setup_steps));
        SETUP(CVodeSetJacEvalFrequency(p->cvode, s->jac_steps));
        if (s->mass_w) {
            s->mass0 = 0.0;
            for (int i = 0; i < p->n; i++)
                s->mass0 += s->mass_w[i] * y0[i];
            SETUP(CVodeSetProjFn(p->cvode, project_mass));
        }
#endif
    } else if (s->kind == KIND_CHEB) {
        p->A = SUNDenseMatrix(neq, neq, p->ctx);
#ifdef ICIDR_LAPACK_DENSE
        p->LS = p->A ? (s->lapack ? SUNLinSol_LapackDense(p->y, p->A, p->ctx) : SUNLinSol_Dense(p->y, p->A, p->ctx))
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
            return -1;
        }
        SETUP(CVodeSetLinearSolver(p->cvode, p->LS, p->A));
        SETUP(CVodeSetJacFn(p->cvode, jac_fn));
    }
    if (s->kind == KIND_CHEB && s->delta_gamma > 0)
        SETUP(CVodeSetDeltaGammaMaxLSetup(p->cvode, s->delta_gamma));
    return 0;
}

static void shear_free(void *data)
{
    Shear *s = data;
    if (!s)
        return;
    free(s->work); free(s->jb); free(s->D); free(s->Jp); free(s->P); free(s->pivots); free(s->z); free(s->x);
    free(s->mass_w);
    free(s);
}

/* a problem of the shear cell of `kind` on n points, with `work` doubles of scratch; NULL where memory runs out */
static Native *shear_new(int kind, int n, const double *params, int n_params, double lo, double hi, size_t work)
{
    /* the state: interleaved (fd, the band ordering) or in blocks (cheb) */
    Native *p = kind == KIND_FD ? problem_new(n, 3, 1, params, n_params, lo, hi)
                                : problem_new(n, 1, n, params, n_params, lo, hi);
    if (!p)
        return NULL;
    Shear *s = calloc(1, sizeof(Shear));
    p->data = s;
    p->free_data = shear_free;
    if (!s || !(s->work = malloc(sizeof(double) * work))) {
        icidr_free(p);
        return NULL;
    }
    s->kind = kind;
    p->rates = shear_rates;
    p->linear_solver = shear_linear_solver;
    return p;
}

/* the problem without CVODE: for the right-hand side, the Jacobian and the time scale alone */
EXPORT Native *icidr_fd_problem(int n, double h, int upwind, const double *ghost, const double *params,
                                int n_params, double lo, double hi)
{
    Native *p = shear_new(KIND_FD, n, params, n_params, lo, hi, 6 * (size_t)n);  /* fd's fields and rates */
    if (!p)
        return NULL;
    Shear *s = SHEAR(p);
    s->h = h;
    s->upwind = upwind;
    memcpy(s->ghost, ghost, sizeof s->ghost);
    s->jb = malloc(sizeof(double) * FD_BAND * 3 * (size_t)n);
    if (!s->jb) {
        icidr_free(p);
        return NULL;
    }
    p->jacobian = fd_timed_jacobian;
    p->jacobian_size = FD_BAND * 3 * (size_t)n;
    return p;
}

/* the Chebyshev problem on n points: D row-major (n, n); `lapack` chooses the dense LU */
EXPORT Native *icidr_cheb_problem(int n, const double *D, const double *params, int n_params, double lo,
                                  double hi, int lapack, double delta_gamma)
{
    Native *p = shear_new(KIND_CHEB, n, params, n_params, lo, hi, 1);
    if (!p)
        return NULL;
    Shear *s = SHEAR(p);
    s->lapack = lapack;
    s->delta_gamma = delta_gamma;
    s->D = malloc(sizeof(double) * (size_t)n * n);
    if (!s->D) {
        icidr_free(p);
        return NULL;
    }
    memcpy(s->D, D, sizeof(double) * (size_t)n * n);
    p->jacobian = shear_jacobian;
    p->jacobian_size = 9 * (size_t)n * n;
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
    Shear *s = SHEAR(p);
    size_t n3 = 3 * (size_t)p->n;
    s->band = band;
    if (band) {
        s->z = malloc(sizeof(double) * p->n);
        s->x = malloc(sizeof(double) * n3);
        s->jb = malloc(sizeof(double) * FD_BAND * n3);
        s->P = malloc(sizeof(double) * CHEB_LDAB * n3);
        if (s->z)
            memcpy(s->z, z, sizeof(double) * p->n);
    } else {
        s->Jp = malloc(sizeof(double) * n3 * n3);
        s->P = malloc(sizeof(double) * n3 * n3);
    }
    s->pivots = malloc(sizeof(int) * n3);
    if (!s->P || !s->pivots || (band ? !s->z || !s->x || !s->jb : !s->Jp))
        return -1;
    p->krylov = 1;
    s->max_krylov = max_krylov;
    s->eps_lin = eps_lin;
    s->setup_steps = setup_steps;
    s->jac_steps = jac_steps;
    return 1;
#else
    return 0;
#endif
}

/* J: (3n, 3n) column-major */
EXPORT void icidr_cheb_jacobian(Native *p, const double *y, double *J)
{
    shear_jacobian(p, y, J);
}

/* cheb: the band preconditioner's J_lo at y on the points z, compact band (FD_BAND_AT) */
EXPORT void icidr_cheb_low_order_jacobian(Native *p, const double *y, const double *z, double *jb)
{
#ifdef ICIDR_KRYLOV
    int neq = 3 * p->n;
    cheb_low_order_jacobian((double *)y, 3, p->n, SHEAR(p)->D, p->n, p->n, (double *)z, p->n, p->params,
                            p->n_params, jb, neq, neq);
#endif
}

EXPORT void icidr_fd_jacobian(Native *p, const double *y, double *jb)
{
    shear_jacobian(p, y, jb);
}

/* cheb, krylov: conserve c . y, c = (w, 0, 0) with the quadrature weights w of phi (n of them),
   by projecting every step (see the file's docstring); returns -1 where memory runs out */
EXPORT int icidr_cheb_conserve(Native *p, const double *w)
{
    Shear *s = SHEAR(p);
    free(s->mass_w);
    s->mass_w = malloc(sizeof(double) * p->n);
    if (!s->mass_w)
        return -1;
    memcpy(s->mass_w, w, sizeof(double) * p->n);
    s->mass_ww = 0.0;
    for (int i = 0; i < p->n; i++)
        s->mass_ww += w[i] * w[i];
    return 0;
}
