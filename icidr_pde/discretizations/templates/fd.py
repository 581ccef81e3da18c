"""Finite-volume right-hand side of the shear cell, a template for any law.

Combined with a law module by :func:`icidr_pde.rheology.codegen.compose`, which replaces
the ``__law__`` import below; see :mod:`icidr_pde.discretizations.fd` for the scheme.
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def padded(data, ghost):
    """data (3, n) with one ghost cell per side: ghost[k, side] = (alpha, beta) gives
    alpha * (edge value) + beta, the affine map of py-pde's boundary setter of field k."""
    n = data.shape[1]
    g = numpy.empty((data.shape[0], n + 2))
    for k in range(data.shape[0]):
        g[k, 1:n + 1] = data[k]
        g[k, 0] = ghost[k, 0, 0] * data[k, 0] + ghost[k, 0, 1]
        g[k, n + 1] = ghost[k, 1, 0] * data[k, n - 1] + ghost[k, 1, 1]
    return g


@njit(cache=True, error_model="numpy")
def rates(data, ghost, h, upwind, params, out):
    """Evolution rates (3, n) of (phi, u, w) into `out`; fluxes on the n + 1 faces."""
    n = data.shape[1]
    g = padded(data, ghost)
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
