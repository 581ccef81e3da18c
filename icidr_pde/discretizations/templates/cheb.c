/* Chebyshev collocation right-hand side of the shear cell and its analytic dense Jacobian, in C.

   A mirror of the numba template templates/cheb.py (`rates`) and of the numpy Jacobian
   of icidr_pde/discretizations/cheb.py (`_cheb_jacobian`; the scheme is described there),
   for the native engine (icidr_pde/native). The state is the py-pde path's vector
   y = (phi_0..phi_{n-1}, u_0..u_{n-1}, w_0..w_{n-1}) at the n Chebyshev-Gauss-Lobatto
   points; D is the differentiation matrix on [0, H] (icidr_pde.chebyshev.diff_matrix),
   row-major D[i * n + j], and DT its transpose (DT[j * n + i] = D[i, j]). The law enters
   through law_stress and law_stress_jacobian (icidr_pde.rheology.ccode), placed before
   this text. u and w are Dirichlet (3.9): their wall rates and wall Jacobian rows are 0.

   The Jacobian is written column-major into J (leading dimension 3n), as SUNDIALS' dense
   matrix stores it. Work arrays: CHEB_WORK(n) doubles. With ICIDR_BLAS (the build found
   the OpenBLAS that scikit-sundae ships with its LAPACK solver) the products with D are
   BLAS dgemv/dgemm, as numpy.dot computes them for the numba and numpy kernels (4.7x and
   4.4x faster than the plain loops below, measured at n = 201). */

#define CHEB_WORK(n) (16 * (n) + (n) * (n))

#ifdef ICIDR_BLAS
enum { CBLAS_ROW_MAJOR = 101, CBLAS_COL_MAJOR = 102, CBLAS_NO_TRANS = 111, CBLAS_TRANS = 112 };
void cblas_dgemv(int order, int trans, int m, int n, double alpha, const double *a, int lda, const double *x,
                 int incx, double beta, double *y, int incy);
void cblas_dgemm(int order, int trans_a, int trans_b, int m, int n, int k, double alpha, const double *a,
                 int lda, const double *b, int ldb, double beta, double *c, int ldc);
void openblas_set_num_threads(int threads);
#endif

/* out = D x (D row-major n x n) */
static void cheb_apply(int n, const double *D, const double *x, double *out)
{
#ifdef ICIDR_BLAS
    cblas_dgemv(CBLAS_ROW_MAJOR, CBLAS_NO_TRANS, n, n, 1.0, D, n, x, 1, 0.0, out, 1);
#else
    for (int i = 0; i < n; i++) {
        const double *row = D + (long)i * n;
        double s = 0.0;
        for (int j = 0; j < n; j++)
            s += row[j] * x[j];
        out[i] = s;
    }
#endif
}

/* out[0..n-1] = D x[0..n-1], out[n..2n-1] = D x[n..2n-1]: one pass over D with BLAS */
static void cheb_apply2(int n, const double *D, const double *x, double *out)
{
#ifdef ICIDR_BLAS
    cblas_dgemm(CBLAS_COL_MAJOR, CBLAS_TRANS, CBLAS_NO_TRANS, n, 2, n, 1.0, D, n, x, n, 0.0, out, n);
#else
    cheb_apply(n, D, x, out);
    cheb_apply(n, D, x + n, out + n);
#endif
}

/* out[k * n + j]: the evolution rate of field k (phi, u, w) at point j */
static void cheb_rates(int n, const double *D, const double *params, const double *y, double *out,
                       double *work)
{
    const double *phi = y, *u = y + n, *w = y + 2 * n;
    double *uz = work, *wz = work + n, *flux_u = work + 2 * n, *flux_w = work + 3 * n, *mass = work + 4 * n;
    double *div_mass = work + 5 * n, *div_u = work + 6 * n, *div_w = work + 7 * n;
    double s[LAW_N_OUTPUTS];
    cheb_apply2(n, D, u, uz);  /* u, w and uz, wz are adjacent */
    for (int j = 0; j < n; j++) {
        law_stress(phi[j], uz[j], wz[j], params, s);
        flux_u[j] = s[1];
        flux_w[j] = s[2] - s[0];
        mass[j] = phi[j] * w[j];
    }
    cheb_apply(n, D, mass, div_mass);
    cheb_apply2(n, D, flux_u, div_u);  /* flux_u, flux_w and div_u, div_w are adjacent */
    for (int i = 0; i < n; i++) {
        out[i] = -div_mass[i];
        out[n + i] = div_u[i] / phi[i] - w[i] * uz[i];
        out[2 * n + i] = div_w[i] / phi[i] - w[i] * wz[i];
    }
    out[n] = out[2 * n - 1] = 0.0;  /* Dirichlet walls (3.9) */
    out[2 * n] = out[3 * n - 1] = 0.0;
}

/* The four products D diag(d_q) D of the velocity columns into J (which holds zeros there).
   BLAS: dgemm of (D diag(d)) and D, each written into its block of J. Else column by column:
   column j of D diag(d) D is D (d * D[:, j]), accumulated as axpys over the columns of D
   (contiguous in DT); vectorised, each element its own sum (no reassociation). */
__attribute__((optimize("O3")))
static void cheb_velocity_columns(int n, const double *DT, const double *dfu1, const double *dfw1,
                                  const double *dfu2, const double *dfw2, double *J, double *tmp)
{
    long ld = 3L * n;
#ifdef ICIDR_BLAS
    const double *d[4] = {dfu1, dfw1, dfu2, dfw2};
    double *block[4] = {J + n * ld + n, J + n * ld + 2 * n, J + 2 * n * ld + n, J + 2 * n * ld + 2 * n};
    for (int q = 0; q < 4; q++) {
        for (int k = 0; k < n; k++)  /* column k of D diag(d): d_k D[:, k] (column-major) */
            for (int i = 0; i < n; i++)
                tmp[(long)k * n + i] = DT[(long)k * n + i] * d[q][k];
        cblas_dgemm(CBLAS_COL_MAJOR, CBLAS_NO_TRANS, CBLAS_NO_TRANS, n, n, n, 1.0, tmp, n, DT, n, 0.0,
                    block[q], (int)ld);
    }
    return;
#endif
    for (int j = 0; j < n; j++) {
        double *uu = J + (n + j) * ld + n, *wu = uu + n;           /* column u_j: rows u, w */
        double *uw = J + (2 * n + j) * ld + n, *ww = uw + n;       /* column w_j: rows u, w */
        const double *Dj = DT + (long)j * n;                        /* D[:, j] */
        for (int k = 0; k < n; k++) {
            const double *Dk = DT + (long)k * n;                    /* D[:, k] */
            double dkj = Dj[k];
            double a = dfu1[k] * dkj, b = dfw1[k] * dkj, c = dfu2[k] * dkj, e = dfw2[k] * dkj;
            for (int i = 0; i < n; i++) {
                uu[i] += Dk[i] * a;
                wu[i] += Dk[i] * b;
                uw[i] += Dk[i] * c;
                ww[i] += Dk[i] * e;
            }
        }
    }
}

static void cheb_jacobian(int n, const double *D, const double *DT, const double *params, const double *y,
                          double *J, double *work)
{
    const double *phi = y, *u = y + n, *w = y + 2 * n;
    double *uz = work, *wz = work + n, *flux_u = work + 2 * n, *flux_w = work + 3 * n;
    double *div_u = work + 4 * n, *div_w = work + 5 * n, *inv_phi = work + 6 * n;
    double *dfu = work + 7 * n, *dfw = work + 10 * n;  /* dF/d(phi, u_z, w_z): 3 arrays of n each */
    double d[LAW_N_OUTPUTS * LAW_N_ARGS], s[LAW_N_OUTPUTS];
    long ld = 3L * n;
    for (long e = 0; e < ld * ld; e++)
        J[e] = 0.0;
    cheb_apply2(n, D, u, uz);
    for (int j = 0; j < n; j++) {
        law_stress(phi[j], uz[j], wz[j], params, s);
        law_stress_jacobian(phi[j], uz[j], wz[j], params, d);
        flux_u[j] = s[1];
        flux_w[j] = s[2] - s[0];
        for (int a = 0; a < 3; a++) {
            dfu[a * n + j] = d[3 + a];
            dfw[a * n + j] = d[6 + a] - d[a];
        }
    }
    cheb_apply2(n, D, flux_u, div_u);
    for (int i = 0; i < n; i++) {
        double interior = (i == 0 || i == n - 1) ? 0.0 : 1.0;
        inv_phi[i] = interior / phi[i];
    }
    /* columns of phi_j: mass rows -D[i, j] w_j; velocity rows (1/phi_i) D[i, j] dF/dphi_j */
    for (int j = 0; j < n; j++) {
        double *col = J + j * ld;
        const double *Dj = DT + (long)j * n;
        for (int i = 0; i < n; i++) {
            col[i] = -Dj[i] * w[j];
            col[n + i] = (inv_phi[i] * Dj[i]) * dfu[j];
            col[2 * n + i] = (inv_phi[i] * Dj[i]) * dfw[j];
        }
    }
    for (int i = 0; i < n; i++) {  /* the 1/phi factor's own derivative */
        double interior = (i == 0 || i == n - 1) ? 0.0 : 1.0;
        J[i * ld + n + i] -= interior * div_u[i] / (phi[i] * phi[i]);
        J[i * ld + 2 * n + i] -= interior * div_w[i] / (phi[i] * phi[i]);
    }
    /* columns of w_j, mass rows: -D[i, j] phi_j */
    for (int j = 0; j < n; j++) {
        double *col = J + (2 * n + j) * ld;
        const double *Dj = DT + (long)j * n;
        for (int i = 0; i < n; i++)
            col[i] = -Dj[i] * phi[j];
    }
    cheb_velocity_columns(n, DT, dfu + n, dfw + n, dfu + 2 * n, dfw + 2 * n, J, work + 16 * n);
    for (int j = 0; j < n; j++) {  /* 1/phi_i, then the advection -w D u, -w D w */
        double *uu = J + (n + j) * ld + n, *wu = uu + n, *uw = J + (2 * n + j) * ld + n, *ww = uw + n;
        const double *Dj = DT + (long)j * n;
        for (int i = 0; i < n; i++) {
            double interior = (i == 0 || i == n - 1) ? 0.0 : 1.0;
            double adv = (interior * w[i]) * Dj[i];
            uu[i] = inv_phi[i] * uu[i] - adv;
            wu[i] = inv_phi[i] * wu[i];
            uw[i] = inv_phi[i] * uw[i];
            ww[i] = inv_phi[i] * ww[i] - adv;
        }
    }
    for (int i = 0; i < n; i++) {
        double interior = (i == 0 || i == n - 1) ? 0.0 : 1.0;
        J[(2 * n + i) * ld + n + i] -= interior * uz[i];
        J[(2 * n + i) * ld + 2 * n + i] -= interior * wz[i];
    }
}
