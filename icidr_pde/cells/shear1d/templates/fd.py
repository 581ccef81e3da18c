"""Finite-volume right-hand side of the shear cell and its analytic Jacobian, a template for any law.

The one source of the scheme's kernels: combined with a law module by
:func:`icidr_pde.rheology.codegen.compose` (which replaces the ``__law__`` import below) for
numba, and printed as C for the native engine by :func:`icidr_pde.native.translate.translate`
(hence the typed parameters and the plain loops: the subset that module accepts); see
:mod:`icidr_pde.cells.shear1d.fd` for the scheme.
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def padded(data: "float64[:, :]", ghost: "float64[:, :, :]", g: "float64[:, :]"):
    """g = data (3, n) with one ghost cell per side: ghost[k, side] = (alpha, beta) gives
    alpha * (edge value) + beta, the affine map of py-pde's boundary setter of field k."""
    n = data.shape[1]
    for k in range(data.shape[0]):
        for i in range(n):
            g[k, i + 1] = data[k, i]
        g[k, 0] = ghost[k, 0, 0] * data[k, 0] + ghost[k, 0, 1]
        g[k, n + 1] = ghost[k, 1, 0] * data[k, n - 1] + ghost[k, 1, 1]


@njit(cache=True, error_model="numpy")
def rates(data: "float64[:, :]", ghost: "float64[:, :, :]", h: "float64", upwind: "boolean",
          params: "float64[:]", out: "float64[:, :]"):
    """Evolution rates (3, n) of (phi, u, w) into `out`; fluxes on the n + 1 faces."""
    n = data.shape[1]
    g = numpy.empty((data.shape[0], n + 2))
    padded(data, ghost, g)
    mass = numpy.empty(n + 1)
    flux_u = numpy.empty(n + 1)
    flux_w = numpy.empty(n + 1)
    for f in range(n + 1):  # face f between cells f - 1 and f (padded indices f, f + 1)
        phi_f = 0.5 * (g[0, f + 1] + g[0, f])
        w_f = 0.5 * (g[2, f + 1] + g[2, f])
        uz = (g[1, f + 1] - g[1, f]) / h
        wz = (g[2, f + 1] - g[2, f]) / h
        p, txz, tzz = law.stress(phi_f, uz, wz, params)
        flux_u[f] = txz
        flux_w[f] = tzz - p
        if upwind:
            phi_up = g[0, f] if w_f > 0 else g[0, f + 1]
        else:
            phi_up = phi_f
        mass[f] = phi_up * w_f
    for i in range(n):
        c = i + 1
        phi = g[0, c]
        w = g[2, c]
        if upwind:
            if w > 0:
                du = (g[1, c] - g[1, c - 1]) / h
                dw = (g[2, c] - g[2, c - 1]) / h
            else:
                du = (g[1, c + 1] - g[1, c]) / h
                dw = (g[2, c + 1] - g[2, c]) / h
        else:
            du = (g[1, c + 1] - g[1, c - 1]) / (2 * h)
            dw = (g[2, c + 1] - g[2, c - 1]) / (2 * h)
        out[0, i] = -(mass[i + 1] - mass[i]) / h
        out[1, i] = (flux_u[i + 1] - flux_u[i]) / (h * phi) - w * du
        out[2, i] = (flux_w[i + 1] - flux_w[i]) / (h * phi) - w * dw


@njit(cache=True, error_model="numpy")
def _add(J: "float64[:, :]", n: "int64", ghost: "float64[:, :, :]", i: "int64", k: "int64", j: "int64",
         m: "int64", value: "float64"):
    """J[row of (cell i, field k), column of (cell j, field m)] += value in the interleaved
    ordering 3 * cell + field; a ghost cell j = -1 or n maps onto its edge cell by alpha."""
    if j < 0:
        j = 0
        value *= ghost[m, 0, 0]
    elif j >= n:
        j = n - 1
        value *= ghost[m, 1, 0]
    J[3 * i + k, 3 * j + m] += value


@njit(cache=True, error_model="numpy")
def jacobian_interleaved(data: "float64[:, :]", ghost: "float64[:, :, :]", h: "float64", upwind: "boolean",
                         params: "float64[:]", J: "float64[:, :]"):
    """Analytic Jacobian of :func:`rates` into the (3n, 3n) array `J`, interleaved ordering
    (phi_0, u_0, w_0, phi_1, ...), band (5, 5). Only the 3 x 3 blocks of cells i, i +- 1 are
    written (zeroed, then accumulated); entries outside them are left as they are.

    Chain rule through the face stencil with the law's exact partials (``law.stress_jacobian``),
    so the phi rows are exact differences of face fluxes: every column of the phi rows sums
    to zero, as the mass flux does."""
    n = data.shape[1]
    g = numpy.empty((data.shape[0], n + 2))
    padded(data, ghost, g)
    flux_u = numpy.empty(n + 1)
    flux_w = numpy.empty(n + 1)
    dflux = numpy.empty((2, 3))  # partials of F_u = tau_xz (row 0) and F_w = tau_zz - p by (phi_f, u_z, w_z)
    for i in range(n):
        for j in range(max(i - 1, 0), min(i + 2, n)):
            for k in range(3):
                for m in range(3):
                    J[3 * i + k, 3 * j + m] = 0.0
    for f in range(n + 1):  # face f: left cell f - 1, right cell f (either may be a ghost)
        left = f - 1
        right = f
        phi_f = 0.5 * (g[0, f + 1] + g[0, f])
        w_f = 0.5 * (g[2, f + 1] + g[2, f])
        uz = (g[1, f + 1] - g[1, f]) / h
        wz = (g[2, f + 1] - g[2, f]) / h
        d = law.stress_jacobian(phi_f, uz, wz, params)
        p, txz, tzz = law.stress(phi_f, uz, wz, params)
        flux_u[f] = txz
        flux_w[f] = tzz - p
        for a in range(3):
            dflux[0, a] = d[3 + a]
            dflux[1, a] = d[6 + a] - d[a]
        if upwind:
            up = left if w_f > 0 else right
            phi_up = g[0, f] if w_f > 0 else g[0, f + 1]
        else:
            up = -2
            phi_up = phi_f
        # cell i receives +F(face i + 1)/h - F(face i)/h: face f enters cell f - 1 with +, cell f with -
        for side in range(2):
            cell = left if side == 0 else right
            if cell < 0 or cell >= n:
                continue
            s = (1.0 if side == 0 else -1.0) / h
            inv_phi = 1.0 / g[0, cell + 1]
            # mass: -(mass[i + 1] - mass[i])/h
            if up == -2:
                _add(J, n, ghost, cell, 0, left, 0, -s * 0.5 * w_f)
                _add(J, n, ghost, cell, 0, right, 0, -s * 0.5 * w_f)
            else:
                _add(J, n, ghost, cell, 0, up, 0, -s * w_f)
            _add(J, n, ghost, cell, 0, left, 2, -s * 0.5 * phi_up)
            _add(J, n, ghost, cell, 0, right, 2, -s * 0.5 * phi_up)
            for q in range(2):  # the u rows (F_u), then the w rows (F_w)
                k = q + 1
                sc = s * inv_phi
                _add(J, n, ghost, cell, k, left, 0, sc * 0.5 * dflux[q, 0])
                _add(J, n, ghost, cell, k, right, 0, sc * 0.5 * dflux[q, 0])
                _add(J, n, ghost, cell, k, left, 1, -sc * dflux[q, 1] / h)
                _add(J, n, ghost, cell, k, right, 1, sc * dflux[q, 1] / h)
                _add(J, n, ghost, cell, k, left, 2, -sc * dflux[q, 2] / h)
                _add(J, n, ghost, cell, k, right, 2, sc * dflux[q, 2] / h)
    for i in range(n):  # 1/phi factor and advection -w d_z
        c = i + 1
        phi = g[0, c]
        w = g[2, c]
        J[3 * i + 1, 3 * i] -= (flux_u[i + 1] - flux_u[i]) / (h * phi * phi)
        J[3 * i + 2, 3 * i] -= (flux_w[i + 1] - flux_w[i]) / (h * phi * phi)
        if upwind:
            if w > 0:
                lo = i - 1
                hi = i
                du = (g[1, c] - g[1, c - 1]) / h
                dw = (g[2, c] - g[2, c - 1]) / h
            else:
                lo = i
                hi = i + 1
                du = (g[1, c + 1] - g[1, c]) / h
                dw = (g[2, c + 1] - g[2, c]) / h
            scale = 1.0 / h
        else:
            lo = i - 1
            hi = i + 1
            du = (g[1, c + 1] - g[1, c - 1]) / (2 * h)
            dw = (g[2, c + 1] - g[2, c - 1]) / (2 * h)
            scale = 0.5 / h
        for k in range(1, 3):
            _add(J, n, ghost, i, k, hi, k, -w * scale)
            _add(J, n, ghost, i, k, lo, k, w * scale)
        J[3 * i + 1, 3 * i + 2] -= du
        J[3 * i + 2, 3 * i + 2] -= dw
