"""Chebyshev collocation right-hand side of the shear cell, a template for any law.

Combined with a law module by :func:`icidr_pde.rheology.codegen.compose`, which replaces
the ``__law__`` import below; see :mod:`icidr_pde.discretizations.cheb` for the scheme.
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def rates(data, D, params, out):
    """Evolution rates (3, n) of (phi, u, w) at the collocation points into `out`."""
    phi = data[0]
    u = data[1]
    w = data[2]
    n = phi.shape[0]
    uz = numpy.dot(D, u)
    wz = numpy.dot(D, w)
    flux_u = numpy.empty(n)
    flux_w = numpy.empty(n)
    for j in range(n):
        p, txz, tzz = law.stress(phi[j], uz[j], wz[j], params)
        flux_u[j] = txz
        flux_w[j] = tzz - p
    div_mass = numpy.dot(D, phi * w)
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
