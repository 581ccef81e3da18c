"""Chebyshev collocation right-hand side of the shear cell and its analytic Jacobian, a template for any law.

The one source of the scheme's kernels: combined with a law module by
:func:`icidr_pde.rheology.codegen.compose` (which replaces the ``__law__`` import below) for
numba, and printed as C for the native engine by :func:`icidr_pde.native.translate.translate`
(hence the typed parameters and the plain loops: the subset that module accepts); see
:mod:`icidr_pde.cells.shear1d.cheb` for the scheme. The products with D are ``numpy.dot``
(BLAS in both forms).
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def gradients(data: "float64[:, :]", D: "float64[:, :]", uz: "float64[:]", wz: "float64[:]"):
    """uz = D u and wz = D w at the collocation points."""
    u = data[1]
    w = data[2]
    numpy.dot(D, u, uz)
    numpy.dot(D, w, wz)


@njit(cache=True, error_model="numpy")
def rates(data: "float64[:, :]", D: "float64[:, :]", params: "float64[:]", out: "float64[:, :]"):
    """Evolution rates (3, n) of (phi, u, w) at the collocation points into `out`."""
    n = data.shape[1]
    uz = numpy.empty(n)
    wz = numpy.empty(n)
    gradients(data, D, uz, wz)
    phi = data[0]
    w = data[2]
    flux_u = numpy.empty(n)
    flux_w = numpy.empty(n)
    mass = numpy.empty(n)
    for j in range(n):
        p, txz, tzz = law.stress(phi[j], uz[j], wz[j], params)
        flux_u[j] = txz
        flux_w[j] = tzz - p
        mass[j] = phi[j] * w[j]
    div_mass = numpy.dot(D, mass)
    div_u = numpy.dot(D, flux_u)
    div_w = numpy.dot(D, flux_w)
    for j in range(n):
        out[0, j] = -div_mass[j]
        out[1, j] = div_u[j] / phi[j] - w[j] * uz[j]
        out[2, j] = div_w[j] / phi[j] - w[j] * wz[j]
    out[1, 0] = 0.0  # Dirichlet walls (3.9)
    out[1, n - 1] = 0.0
    out[2, 0] = 0.0
    out[2, n - 1] = 0.0


@njit(cache=True, error_model="numpy")
def law_partials(data: "float64[:, :]", D: "float64[:, :]", params: "float64[:]", uz: "float64[:]",
                 wz: "float64[:]", flux: "float64[:, :]", dflux: "float64[:, :]"):
    """The rates uz = D u, wz = D w, the fluxes flux = (F_u, F_w) = (tau_xz, tau_zz - p) at the
    points and their partials dflux = (dF_u/d(phi, u_z, w_z), dF_w/d(phi, u_z, w_z)), from the
    law's kernels."""
    n = data.shape[1]
    gradients(data, D, uz, wz)
    phi = data[0]
    for j in range(n):
        p, txz, tzz = law.stress(phi[j], uz[j], wz[j], params)
        d = law.stress_jacobian(phi[j], uz[j], wz[j], params)
        flux[0, j] = txz
        flux[1, j] = tzz - p
        for a in range(3):
            dflux[a, j] = d[3 + a]
            dflux[3 + a, j] = d[6 + a] - d[a]


@njit(cache=True, error_model="numpy")
def jacobian(data: "float64[:, :]", D: "float64[:, :]", params: "float64[:]", J: "float64[:, :]"):
    """Analytic dense Jacobian (3n, 3n) of :func:`rates` into `J`, the state in blocks (phi, u, w):
    the law's fluxes and exact partials at the points and the products D diag(dF/du_z) D,
    then :func:`assemble_jacobian`."""
    n = data.shape[1]
    uz = numpy.empty(n)
    wz = numpy.empty(n)
    flux = numpy.empty((2, n))
    dflux = numpy.empty((6, n))
    law_partials(data, D, params, uz, wz, flux, dflux)
    products = numpy.empty((4, n, n))
    scaled = numpy.empty((n, n))
    for block in range(4):  # (F_u, F_w) by (u_z, w_z)
        for i in range(n):
            for k in range(n):
                scaled[i, k] = D[i, k] * dflux[3 * (block // 2) + 1 + block % 2, k]
        product = products[block]
        numpy.dot(scaled, D, product)
    assemble_jacobian(data, D, uz, wz, flux, dflux, products, J)


@njit(cache=True, error_model="numpy")
def assemble_jacobian(data: "float64[:, :]", D: "float64[:, :]", uz: "float64[:]", wz: "float64[:]",
                      flux: "float64[:, :]", dflux: "float64[:, :]", products: "float64[:, :, :]",
                      J: "float64[:, :]"):
    """The chain rule through D into `J` (3n, 3n), given the rates uz = D u, wz = D w, the
    fluxes flux = (F_u, F_w) = (tau_xz, tau_zz - p) and their partials dflux = (dF_u/d(phi,
    u_z, w_z), dF_w/d(phi, u_z, w_z)) at the points, and the velocity columns' products
    D diag(dF/d(u_z, w_z)) D: products[2 * a + b] for F_u, F_w (a) by u_z, w_z (b). The wall
    rows of u and w are 0 (Dirichlet)."""
    phi = data[0]
    w = data[2]
    n = phi.shape[0]
    interior = numpy.empty(n)
    inv_phi = numpy.empty(n)
    for j in range(n):
        interior[j] = 0.0 if j == 0 or j == n - 1 else 1.0
        inv_phi[j] = interior[j] / phi[j]
    flux_u = flux[0]
    flux_w = flux[1]
    div_u = numpy.dot(D, flux_u)
    div_w = numpy.dot(D, flux_w)
    # every loop over J runs down the columns (rows innermost): the native engine's J is
    # column-major (SUNDIALS' dense matrix), the py-pde path's is allocated so (order F)
    for c in range(3 * n):
        for r in range(3 * n):
            J[r, c] = 0.0
    for j in range(n):  # the phi columns; the mass rows' w columns
        for i in range(n):
            J[i, j] = -D[i, j] * w[j]
            J[i, 2 * n + j] = -D[i, j] * phi[j]
            J[n + i, j] = inv_phi[i] * D[i, j] * dflux[0, j]
            J[2 * n + i, j] = inv_phi[i] * D[i, j] * dflux[3, j]
    for i in range(n):
        J[n + i, i] -= interior[i] * div_u[i] / (phi[i] * phi[i])
        J[2 * n + i, i] -= interior[i] * div_w[i] / (phi[i] * phi[i])
    for block in range(4):  # rows of u (F_u), w (F_w) by columns of u (d/du_z), w (d/dw_z)
        row = block // 2
        col = block % 2
        for j in range(n):
            for i in range(n):
                J[(1 + row) * n + i, (1 + col) * n + j] = inv_phi[i] * products[block, i, j]
    for j in range(n):  # the advection -w D u, -w D w
        for i in range(n):
            adv = interior[i] * w[i]
            J[n + i, n + j] -= adv * D[i, j]
            J[2 * n + i, 2 * n + j] -= adv * D[i, j]
    for i in range(n):
        J[n + i, 2 * n + i] -= interior[i] * uz[i]
        J[2 * n + i, 2 * n + i] -= interior[i] * wz[i]


@njit(cache=True, error_model="numpy")
def low_order_jacobian(data: "float64[:, :]", D: "float64[:, :]", z: "float64[:]", params: "float64[:]",
                       B: "float64[:, :]"):
    """The Jacobian of :func:`rates` with D replaced by low-order differences on the same points
    z (the preconditioner of the Newton-Krylov path; Orszag 1980, Canuto et al. 1988 sec. 5.2):
    the law's partials at the points as in :func:`jacobian`, d/dz by the three-point difference
    (one-sided two-point at the walls) and D diag(a) D by the compact three-point operator
    (a_{i+1/2} (x_{i+1} - x_i)/h_i - a_{i-1/2} (x_i - x_{i-1})/h_{i-1}) / ((h_i + h_{i-1})/2),
    a_{i+1/2} = (a_i + a_{i+1})/2. Into `B` (3n, 3n) in the interleaved ordering (phi_0, u_0,
    w_0, phi_1, ...), a band (5, 5): only entries within the band are written."""
    n = data.shape[1]
    flux = numpy.empty((2, n))  # the fluxes and the law's partials at the points, as in jacobian
    dflux = numpy.empty((6, n))
    uz = numpy.empty(n)
    wz = numpy.empty(n)
    law_partials(data, D, params, uz, wz, flux, dflux)
    phi = data[0]
    w = data[2]
    flux_u = flux[0]
    flux_w = flux[1]
    div_u = numpy.dot(D, flux_u)
    div_w = numpy.dot(D, flux_w)
    for c in range(3 * n):
        for r in range(max(c - 5, 0), min(c + 6, 3 * n)):
            B[r, c] = 0.0
    g = numpy.empty(3)
    for i in range(n):
        if i == 0:
            g[0] = 0.0
            g[1] = -1.0 / (z[1] - z[0])
            g[2] = 1.0 / (z[1] - z[0])
        elif i == n - 1:
            g[0] = -1.0 / (z[i] - z[i - 1])
            g[1] = 1.0 / (z[i] - z[i - 1])
            g[2] = 0.0
        else:
            hm = z[i] - z[i - 1]
            hp = z[i + 1] - z[i]
            g[0] = -hp / (hm * (hm + hp))
            g[1] = (hp - hm) / (hm * hp)
            g[2] = hm / (hp * (hm + hp))
        for q in range(3):  # the mass rows, at the walls too
            m = i - 1 + q
            if m < 0 or m > n - 1:
                continue
            B[3 * i, 3 * m] += -g[q] * w[m]
            B[3 * i, 3 * m + 2] += -g[q] * phi[m]
        if i == 0 or i == n - 1:
            continue  # Dirichlet rows of u and w (3.9)
        inv_phi = 1.0 / phi[i]
        for q in range(3):
            m = i - 1 + q
            B[3 * i + 1, 3 * m] += inv_phi * g[q] * dflux[0, m]
            B[3 * i + 2, 3 * m] += inv_phi * g[q] * dflux[3, m]
            B[3 * i + 1, 3 * m + 1] -= w[i] * g[q]
            B[3 * i + 2, 3 * m + 2] -= w[i] * g[q]
        B[3 * i + 1, 3 * i] -= div_u[i] / (phi[i] * phi[i])
        B[3 * i + 2, 3 * i] -= div_w[i] / (phi[i] * phi[i])
        B[3 * i + 1, 3 * i + 2] -= uz[i]
        B[3 * i + 2, 3 * i + 2] -= wz[i]
        scale = 2.0 * inv_phi / ((z[i + 1] - z[i]) + (z[i] - z[i - 1]))
        for block in range(4):  # rows of u (F_u), w (F_w) by columns of u (d/du_z), w (d/dw_z)
            row = 3 * i + 1 + block // 2
            col = 1 + block % 2
            k = 3 * (block // 2) + 1 + block % 2
            up = scale * 0.5 * (dflux[k, i] + dflux[k, i + 1]) / (z[i + 1] - z[i])
            down = scale * 0.5 * (dflux[k, i] + dflux[k, i - 1]) / (z[i] - z[i - 1])
            B[row, 3 * (i + 1) + col] += up
            B[row, 3 * i + col] -= up + down
            B[row, 3 * (i - 1) + col] += down
