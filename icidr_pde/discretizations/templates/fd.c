/* Finite-volume right-hand side of the shear cell and its analytic band Jacobian, in C.

   A line-by-line mirror of the numba template templates/fd.py (`padded`, `rates`,
   `jacobian_interleaved`; see icidr_pde/discretizations/fd.py for the scheme), written on
   the interleaved vector y[3 i + k] = field k (phi, u, w) of cell i that CVODE integrates,
   for the native engine (icidr_pde/native). The law enters through law_stress and
   law_stress_jacobian, printed from the law's sympy definition by
   icidr_pde.rheology.ccode and placed before this text. ghost[(k * 2 + s) * 2 + a] is the
   (3, 2, 2) array of ShearCellPDE.ghost_coefficients: the ghost value of field k at side s
   is ghost[.., 0] * edge + ghost[.., 1].

   The Jacobian is written into a compact band jb[col * FD_BAND + row - col + FD_LOWER]
   (bandwidths 5 and 5 of the interleaved ordering): every entry the numba kernel writes,
   accumulated in the same order. Work arrays: FD_WORK(n) doubles. */

#define FD_LOWER 5
#define FD_BAND 11
#define FD_WORK(n) (6 * (n) + 9)

static void fd_padded(int n, const double *y, const double *ghost, double *g)
{
    for (int k = 0; k < 3; k++) {
        double *gk = g + k * (n + 2);
        for (int i = 0; i < n; i++)
            gk[i + 1] = y[3 * i + k];
        gk[0] = ghost[(k * 2 + 0) * 2 + 0] * y[k] + ghost[(k * 2 + 0) * 2 + 1];
        gk[n + 1] = ghost[(k * 2 + 1) * 2 + 0] * y[3 * (n - 1) + k] + ghost[(k * 2 + 1) * 2 + 1];
    }
}

/* out[3 i + k]: the evolution rates; fluxes on the n + 1 faces */
static void fd_rates(int n, double h, int upwind, const double *ghost, const double *params,
                     const double *y, double *out, double *work)
{
    double *g = work, *mass = work + 3 * (n + 2), *flux_u = mass + (n + 1), *flux_w = flux_u + (n + 1);
    const double *g0 = g, *g1 = g + (n + 2), *g2 = g + 2 * (n + 2);
    double s[LAW_N_OUTPUTS];
    fd_padded(n, y, ghost, g);
    for (int f = 0; f < n + 1; f++) {  /* face f between cells f - 1 and f (padded f, f + 1) */
        double phi_f = 0.5 * (g0[f + 1] + g0[f]);
        double w_f = 0.5 * (g2[f + 1] + g2[f]);
        double uz = (g1[f + 1] - g1[f]) / h;
        double wz = (g2[f + 1] - g2[f]) / h;
        law_stress(phi_f, uz, wz, params, s);
        flux_u[f] = s[1];
        flux_w[f] = s[2] - s[0];
        double phi_up = upwind ? (w_f > 0 ? g0[f] : g0[f + 1]) : phi_f;
        mass[f] = phi_up * w_f;
    }
    for (int i = 0; i < n; i++) {
        int c = i + 1;
        double phi = g0[c], w = g2[c], du, dw;
        if (upwind) {
            if (w > 0) {
                du = (g1[c] - g1[c - 1]) / h;
                dw = (g2[c] - g2[c - 1]) / h;
            } else {
                du = (g1[c + 1] - g1[c]) / h;
                dw = (g2[c + 1] - g2[c]) / h;
            }
        } else {
            du = (g1[c + 1] - g1[c - 1]) / (2 * h);
            dw = (g2[c + 1] - g2[c - 1]) / (2 * h);
        }
        out[3 * i + 0] = -(mass[i + 1] - mass[i]) / h;
        out[3 * i + 1] = (flux_u[i + 1] - flux_u[i]) / (h * phi) - w * du;
        out[3 * i + 2] = (flux_w[i + 1] - flux_w[i]) / (h * phi) - w * dw;
    }
}

/* jb[row of (cell i, field k), column of (cell j, field m)] += value; a ghost cell j = -1
   or n maps onto its edge cell by alpha */
static inline void fd_add(double *jb, int n, const double *ghost, int i, int k, int j, int m, double value)
{
    if (j < 0) {
        j = 0;
        value *= ghost[(m * 2 + 0) * 2 + 0];
    } else if (j >= n) {
        j = n - 1;
        value *= ghost[(m * 2 + 1) * 2 + 0];
    }
    int row = 3 * i + k, col = 3 * j + m;
    jb[col * FD_BAND + row - col + FD_LOWER] += value;
}

static void fd_jacobian(int n, double h, int upwind, const double *ghost, const double *params,
                        const double *y, double *jb, double *work)
{
    double *g = work, *flux_u = work + 3 * (n + 2), *flux_w = flux_u + (n + 1);
    const double *g0 = g, *g1 = g + (n + 2), *g2 = g + 2 * (n + 2);
    double d[LAW_N_OUTPUTS * LAW_N_ARGS], s[LAW_N_OUTPUTS];
    fd_padded(n, y, ghost, g);
    for (long e = 0; e < (long)FD_BAND * 3 * n; e++)
        jb[e] = 0.0;
    for (int f = 0; f < n + 1; f++) {  /* face f: left cell f - 1, right cell f (either may be a ghost) */
        int left = f - 1, right = f, up;
        double phi_f = 0.5 * (g0[f + 1] + g0[f]);
        double w_f = 0.5 * (g2[f + 1] + g2[f]);
        double uz = (g1[f + 1] - g1[f]) / h;
        double wz = (g2[f + 1] - g2[f]) / h;
        double phi_up;
        law_stress_jacobian(phi_f, uz, wz, params, d);
        law_stress(phi_f, uz, wz, params, s);
        flux_u[f] = s[1];
        flux_w[f] = s[2] - s[0];
        /* partials of F_u = tau_xz and F_w = tau_zz - p by (phi_f, u_z, w_z) */
        double dflux[2][3] = {{d[3], d[4], d[5]}, {d[6] - d[0], d[7] - d[1], d[8] - d[2]}};
        if (upwind) {
            up = w_f > 0 ? left : right;
            phi_up = w_f > 0 ? g0[f] : g0[f + 1];
        } else {
            up = -2;
            phi_up = phi_f;
        }
        /* cell i receives +F(face i + 1)/h - F(face i)/h */
        for (int side = 0; side < 2; side++) {
            int cell = side == 0 ? left : right;
            double sign = side == 0 ? 1.0 : -1.0;
            if (cell < 0 || cell >= n)
                continue;
            double sh = sign / h;
            double inv_phi = 1.0 / g0[cell + 1];
            if (up == -2) {
                fd_add(jb, n, ghost, cell, 0, left, 0, -sh * 0.5 * w_f);
                fd_add(jb, n, ghost, cell, 0, right, 0, -sh * 0.5 * w_f);
            } else {
                fd_add(jb, n, ghost, cell, 0, up, 0, -sh * w_f);
            }
            fd_add(jb, n, ghost, cell, 0, left, 2, -sh * 0.5 * phi_up);
            fd_add(jb, n, ghost, cell, 0, right, 2, -sh * 0.5 * phi_up);
            for (int q = 0; q < 2; q++) {
                int k = q + 1;
                double c = sh * inv_phi;
                fd_add(jb, n, ghost, cell, k, left, 0, c * 0.5 * dflux[q][0]);
                fd_add(jb, n, ghost, cell, k, right, 0, c * 0.5 * dflux[q][0]);
                fd_add(jb, n, ghost, cell, k, left, 1, -c * dflux[q][1] / h);
                fd_add(jb, n, ghost, cell, k, right, 1, c * dflux[q][1] / h);
                fd_add(jb, n, ghost, cell, k, left, 2, -c * dflux[q][2] / h);
                fd_add(jb, n, ghost, cell, k, right, 2, c * dflux[q][2] / h);
            }
        }
    }
    for (int i = 0; i < n; i++) {  /* 1/phi factor and advection -w d_z */
        int c = i + 1, lo, hi;
        double phi = g0[c], w = g2[c], du, dw, scale;
        jb[(3 * i) * FD_BAND + 1 + FD_LOWER] -= (flux_u[i + 1] - flux_u[i]) / (h * phi * phi);
        jb[(3 * i) * FD_BAND + 2 + FD_LOWER] -= (flux_w[i + 1] - flux_w[i]) / (h * phi * phi);
        if (upwind) {
            if (w > 0) {
                lo = i - 1;
                hi = i;
                du = (g1[c] - g1[c - 1]) / h;
                dw = (g2[c] - g2[c - 1]) / h;
            } else {
                lo = i;
                hi = i + 1;
                du = (g1[c + 1] - g1[c]) / h;
                dw = (g2[c + 1] - g2[c]) / h;
            }
            scale = 1.0 / h;
        } else {
            lo = i - 1;
            hi = i + 1;
            du = (g1[c + 1] - g1[c - 1]) / (2 * h);
            dw = (g2[c + 1] - g2[c - 1]) / (2 * h);
            scale = 0.5 / h;
        }
        for (int k = 1; k < 3; k++) {
            fd_add(jb, n, ghost, i, k, hi, k, -w * scale);
            fd_add(jb, n, ghost, i, k, lo, k, w * scale);
        }
        jb[(3 * i + 2) * FD_BAND + 1 - 2 + FD_LOWER] -= du;  /* row 3i + 1, column 3i + 2 */
        jb[(3 * i + 2) * FD_BAND + FD_LOWER] -= dw;          /* row 3i + 2, column 3i + 2 */
    }
}
