/* The compiled problem of the 2-D x-periodic cell (finite volumes on nx x nz cells) for the CVODE
   driver (icidr_pde/native/cvode_driver.c, which integrates it; problem.h says what a problem is
   to it), in a library of its own (the law of plane flow).

   Newton-Krylov as icidr_pde.engines.sundae's 'GMRES' on a thick cell: SUNDIALS' GMRES (SPGMR,
   its default Gram-Schmidt) without a preconditioner, Krylov dimension and tolerance factor
   (eps_lin) given, CVODE's difference-quotient products J v; the state the fields in blocks,
   (3, nx, nz) row-major. Placed after the law (icidr_pde.rheology.ccode), kernel_support.c and
   the kernels printed from the numba template templates/plane2d.py (icidr_pde.native.translate:
   plane2d_halo_into, plane2d_patch_rates). */

typedef struct {
    int nx, nz;           /* cells along x (periodic) and z */
    double hx, hz;        /* cell widths */
    int upwind;
    double ghost[12];
    double *work;         /* the patch: the whole grid with its ghost layer, (3, nx + 2, nz + 2) */
    int max_krylov;       /* Krylov subspace dimension */
    double eps_lin;       /* GMRES tolerance factor (CVODE's eplifac) */
} Plane;

static void plane_rates(Native *p, const double *y, double *out)
{
    Plane *c = p->data;
    long nx = c->nx, nz = c->nz;
    plane2d_halo_into((double *)y, 3, nx, nz, c->ghost, 3, 2, 2, c->work, 3, nx + 2, nz + 2);
    plane2d_patch_rates(c->work, 3, nx + 2, nz + 2, c->hx, c->hz, c->upwind, p->params, p->n_params, out, 3, nx, nz);
}

/* GMRES without a preconditioner (the build has SPGMR: icidr_plane2d_problem made none otherwise) */
static int plane_linear_solver(Native *p, const double *y0, char *error, int error_len)
{
#ifdef ICIDR_SPGMR
    Plane *c = p->data;
    p->LS = SUNLinSol_SPGMR(p->y, SUN_PREC_NONE, c->max_krylov, p->ctx);
    if (!p->LS) {
        snprintf(error, error_len, "SPGMR not created");
        return -1;
    }
    SETUP(CVodeSetLinearSolver(p->cvode, p->LS, NULL));
    SETUP(CVodeSetEpsLin(p->cvode, c->eps_lin));
#endif
    return 0;
}

static void plane_free(void *data)
{
    Plane *c = data;
    if (!c)
        return;
    free(c->work);
    free(c);
}

/* the 2-D cell on nx x nz cells of widths hx, hz (ghost: the walls' maps, (3, 2, 2)), integrated by
   GMRES(max_krylov) without a preconditioner at the tolerance factor eps_lin; NULL where memory runs
   out or the build has no SPGMR */
EXPORT Native *icidr_plane2d_problem(int nx, int nz, double hx, double hz, int upwind, const double *ghost,
                                     const double *params, int n_params, double lo, double hi, int max_krylov,
                                     double eps_lin)
{
#ifdef ICIDR_SPGMR
    Native *p = problem_new(nx * nz, 1, nx * nz, params, n_params, lo, hi);  /* the fields in blocks */
    if (!p)
        return NULL;
    Plane *c = calloc(1, sizeof(Plane));
    p->data = c;
    p->free_data = plane_free;
    if (!c || !(c->work = malloc(sizeof(double) * 3 * ((size_t)nx + 2) * ((size_t)nz + 2)))) {
        icidr_free(p);
        return NULL;
    }
    c->nx = nx;
    c->nz = nz;
    c->hx = hx;
    c->hz = hz;
    c->upwind = upwind;
    memcpy(c->ghost, ghost, sizeof c->ghost);
    c->max_krylov = max_krylov;
    c->eps_lin = eps_lin;
    p->krylov = 1;
    p->rates = plane_rates;
    p->linear_solver = plane_linear_solver;
    return p;
#else
    return NULL;
#endif
}
