"""Finite-volume right-hand side of the 2-D x-periodic shear cell, a template for any law.

Combined with a law module of the ``plane_flow`` kinematics by
:func:`icidr_pde.rheology.codegen.compose`, which replaces the ``__law__`` import below;
see :mod:`icidr_pde.discretizations.cartesian2d` for the scheme. Data are (3, nx, nz):
(phi, u, w) on cell (i, j); x is periodic, the walls z = 0, H enter through ghost rows.
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def padded(data, ghost):
    """data (3, nx, nz) with one ghost row per wall: ghost[k, side] = (alpha, beta) gives
    alpha * (edge value) + beta, the affine map of py-pde's boundary setter of field k."""
    nf, nx, nz = data.shape
    g = numpy.empty((nf, nx, nz + 2))
    for k in range(nf):
        for i in range(nx):
            g[k, i, 1:nz + 1] = data[k, i]
            g[k, i, 0] = ghost[k, 0, 0] * data[k, i, 0] + ghost[k, 0, 1]
            g[k, i, nz + 1] = ghost[k, 1, 0] * data[k, i, nz - 1] + ghost[k, 1, 1]
    return g


@njit(cache=True, error_model="numpy")
def rates(data, ghost, hx, hz, upwind, params, out):
    """Evolution rates (3, nx, nz) of (phi, u, w) into `out`.

    Stresses on the nx (nz + 1) z-faces and the nx nz x-faces from the compact normal
    difference and the four-cell average of the tangential one; mass in flux form.
    """
    _, nx, nz = data.shape
    g = padded(data, ghost)
    # z-faces (i, f): between padded rows f and f + 1
    mass_z = numpy.empty((nx, nz + 1))
    fu_z = numpy.empty((nx, nz + 1))
    fw_z = numpy.empty((nx, nz + 1))
    for i in range(nx):
        ip = (i + 1) % nx
        im = (i - 1) % nx
        for f in range(nz + 1):
            phi_f = 0.5 * (g[0, i, f + 1] + g[0, i, f])
            w_f = 0.5 * (g[2, i, f + 1] + g[2, i, f])
            ux = (g[1, ip, f] - g[1, im, f] + g[1, ip, f + 1] - g[1, im, f + 1]) / (4 * hx)
            uz = (g[1, i, f + 1] - g[1, i, f]) / hz
            wx = (g[2, ip, f] - g[2, im, f] + g[2, ip, f + 1] - g[2, im, f + 1]) / (4 * hx)
            wz = (g[2, i, f + 1] - g[2, i, f]) / hz
            p, txx, txz, tzz = law.stress(phi_f, ux, uz, wx, wz, params)
            fu_z[i, f] = txz
            fw_z[i, f] = tzz - p
            if upwind:
                phi_up = g[0, i, f] if w_f > 0 else g[0, i, f + 1]
            else:
                phi_up = phi_f
            mass_z[i, f] = phi_up * w_f
    # x-faces (i, j): between cells i and i + 1 (periodic) of padded row c = j + 1
    mass_x = numpy.empty((nx, nz))
    fu_x = numpy.empty((nx, nz))
    fw_x = numpy.empty((nx, nz))
    for i in range(nx):
        ip = (i + 1) % nx
        for j in range(nz):
            c = j + 1
            phi_f = 0.5 * (g[0, i, c] + g[0, ip, c])
            u_f = 0.5 * (g[1, i, c] + g[1, ip, c])
            ux = (g[1, ip, c] - g[1, i, c]) / hx
            uz = (g[1, i, c + 1] - g[1, i, c - 1] + g[1, ip, c + 1] - g[1, ip, c - 1]) / (4 * hz)
            wx = (g[2, ip, c] - g[2, i, c]) / hx
            wz = (g[2, i, c + 1] - g[2, i, c - 1] + g[2, ip, c + 1] - g[2, ip, c - 1]) / (4 * hz)
            p, txx, txz, tzz = law.stress(phi_f, ux, uz, wx, wz, params)
            fu_x[i, j] = txx - p
            fw_x[i, j] = txz
            if upwind:
                phi_up = g[0, i, c] if u_f > 0 else g[0, ip, c]
            else:
                phi_up = phi_f
            mass_x[i, j] = phi_up * u_f
    for i in range(nx):
        ip = (i + 1) % nx
        im = (i - 1) % nx
        for j in range(nz):
            c = j + 1
            phi = g[0, i, c]
            u = g[1, i, c]
            w = g[2, i, c]
            if upwind:
                if u > 0:
                    dux = (g[1, i, c] - g[1, im, c]) / hx
                    dwx = (g[2, i, c] - g[2, im, c]) / hx
                else:
                    dux = (g[1, ip, c] - g[1, i, c]) / hx
                    dwx = (g[2, ip, c] - g[2, i, c]) / hx
                if w > 0:
                    duz = (g[1, i, c] - g[1, i, c - 1]) / hz
                    dwz = (g[2, i, c] - g[2, i, c - 1]) / hz
                else:
                    duz = (g[1, i, c + 1] - g[1, i, c]) / hz
                    dwz = (g[2, i, c + 1] - g[2, i, c]) / hz
            else:
                dux = (g[1, ip, c] - g[1, im, c]) / (2 * hx)
                dwx = (g[2, ip, c] - g[2, im, c]) / (2 * hx)
                duz = (g[1, i, c + 1] - g[1, i, c - 1]) / (2 * hz)
                dwz = (g[2, i, c + 1] - g[2, i, c - 1]) / (2 * hz)
            # z terms first, in the 1-D scheme's order: x-independent data give its rates
            out[0, i, j] = -(mass_z[i, j + 1] - mass_z[i, j]) / hz - (mass_x[i, j] - mass_x[im, j]) / hx
            out[1, i, j] = ((fu_z[i, j + 1] - fu_z[i, j]) / (hz * phi) - w * duz
                            + (fu_x[i, j] - fu_x[im, j]) / (hx * phi) - u * dux)
            out[2, i, j] = ((fw_z[i, j + 1] - fw_z[i, j]) / (hz * phi) - w * dwz
                            + (fw_x[i, j] - fw_x[im, j]) / (hx * phi) - u * dwx)
