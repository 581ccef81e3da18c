"""Finite-volume right-hand side of the 2-D x-periodic shear cell, a template for any law.

Combined with a law module of the ``plane_flow`` kinematics by
:func:`icidr_pde.rheology.codegen.compose`, which replaces the ``__law__`` import below;
see :mod:`icidr_pde.cells.plane2d.pde` for the scheme. Data are (3, nx, nz):
(phi, u, w) on cell (i, j); x is periodic, the walls z = 0, H enter through ghost rows.

The scheme is written once, on a *patch*: a block of (mx, mz) cells with one ghost layer
around it, (3, mx + 2, mz + 2), as a distributed array's local part holds it (its x ghosts
from the neighbouring block or the periodic image, its z ghosts from the neighbouring block
or, at a wall, the wall's ghost row). The whole grid is the one patch whose x ghosts are the
periodic columns and whose z ghosts are both walls' rows (:func:`halo`).
"""
import numpy
from numba import njit

import __law__ as law


@njit(cache=True, error_model="numpy")
def walls(g: "float64[:, :, :]", ghost: "float64[:, :, :]", low: "boolean", high: "boolean"):
    """Fill the wall ghost rows of the patch g (3, mx + 2, mz + 2) in place, every column of it
    (its x ghosts too): row 0 if the patch touches z = 0 (`low`), row mz + 1 if it touches z = H
    (`high`). ghost[k, side] = (alpha, beta) gives alpha * (edge value) + beta, the affine map
    of py-pde's boundary setter of field k."""
    nf, px, pz = g.shape
    for k in range(nf):
        for a in range(px):
            if low:
                g[k, a, 0] = ghost[k, 0, 0] * g[k, a, 1] + ghost[k, 0, 1]
            if high:
                g[k, a, pz - 1] = ghost[k, 1, 0] * g[k, a, pz - 2] + ghost[k, 1, 1]


@njit(cache=True, error_model="numpy")
def halo_into(data: "float64[:, :, :]", ghost: "float64[:, :, :]", g: "float64[:, :, :]"):
    """g (3, nx + 2, nz + 2) = the whole grid data (3, nx, nz) as one patch: x ghosts the
    periodic columns, z ghosts the walls' rows."""
    nf, nx, nz = data.shape
    for k in range(nf):
        for i in range(nx):
            for j in range(nz):
                g[k, i + 1, j + 1] = data[k, i, j]
        for j in range(nz):
            g[k, 0, j + 1] = data[k, nx - 1, j]
            g[k, nx + 1, j + 1] = data[k, 0, j]
    walls(g, ghost, True, True)


@njit(cache=True, error_model="numpy")
def halo(data, ghost):
    """The whole grid data (3, nx, nz) as one patch (3, nx + 2, nz + 2) (:func:`halo_into`)."""
    nf, nx, nz = data.shape
    g = numpy.empty((nf, nx + 2, nz + 2))
    halo_into(data, ghost, g)
    return g


@njit(cache=True, error_model="numpy")
def patch_rates(g: "float64[:, :, :]", hx: "float64", hz: "float64", upwind: "boolean", params: "float64[:]",
                out: "float64[:, :, :]"):
    """Evolution rates (3, mx, mz) of (phi, u, w) on the cells of the filled patch g
    (3, mx + 2, mz + 2) into `out`; cell (a, b) of the patch is out[:, a - 1, b - 1].

    Stresses on the mx (mz + 1) z-faces and the (mx + 1) mz x-faces from the compact normal
    difference and the four-cell average of the tangential one; mass in flux form.
    """
    _, px, pz = g.shape
    mx, mz = px - 2, pz - 2
    # z-faces (a, f): between patch rows f and f + 1 of column a + 1
    mass_z = numpy.empty((mx, mz + 1))
    fu_z = numpy.empty((mx, mz + 1))
    fw_z = numpy.empty((mx, mz + 1))
    for a in range(mx):
        i, ip, im = a + 1, a + 2, a
        for f in range(mz + 1):
            phi_f = 0.5 * (g[0, i, f + 1] + g[0, i, f])
            w_f = 0.5 * (g[2, i, f + 1] + g[2, i, f])
            ux = (g[1, ip, f] - g[1, im, f] + g[1, ip, f + 1] - g[1, im, f + 1]) / (4 * hx)
            uz = (g[1, i, f + 1] - g[1, i, f]) / hz
            wx = (g[2, ip, f] - g[2, im, f] + g[2, ip, f + 1] - g[2, im, f + 1]) / (4 * hx)
            wz = (g[2, i, f + 1] - g[2, i, f]) / hz
            p, txx, txz, tzz = law.stress(phi_f, ux, uz, wx, wz, params)
            fu_z[a, f] = txz
            fw_z[a, f] = tzz - p
            if upwind:
                phi_up = g[0, i, f] if w_f > 0 else g[0, i, f + 1]
            else:
                phi_up = phi_f
            mass_z[a, f] = phi_up * w_f
    # x-faces (a, j): between patch columns a and a + 1 of row c = j + 1
    mass_x = numpy.empty((mx + 1, mz))
    fu_x = numpy.empty((mx + 1, mz))
    fw_x = numpy.empty((mx + 1, mz))
    for a in range(mx + 1):
        i, ip = a, a + 1
        for j in range(mz):
            c = j + 1
            phi_f = 0.5 * (g[0, i, c] + g[0, ip, c])
            u_f = 0.5 * (g[1, i, c] + g[1, ip, c])
            ux = (g[1, ip, c] - g[1, i, c]) / hx
            uz = (g[1, i, c + 1] - g[1, i, c - 1] + g[1, ip, c + 1] - g[1, ip, c - 1]) / (4 * hz)
            wx = (g[2, ip, c] - g[2, i, c]) / hx
            wz = (g[2, i, c + 1] - g[2, i, c - 1] + g[2, ip, c + 1] - g[2, ip, c - 1]) / (4 * hz)
            p, txx, txz, tzz = law.stress(phi_f, ux, uz, wx, wz, params)
            fu_x[a, j] = txx - p
            fw_x[a, j] = txz
            if upwind:
                phi_up = g[0, i, c] if u_f > 0 else g[0, ip, c]
            else:
                phi_up = phi_f
            mass_x[a, j] = phi_up * u_f
    for a in range(mx):
        i, ip, im = a + 1, a + 2, a
        for j in range(mz):
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
            # z terms first, in the 1-D scheme's order: x-independent data give its rates;
            # x-face a + 1 is the cell's right face, a its left
            out[0, a, j] = -(mass_z[a, j + 1] - mass_z[a, j]) / hz - (mass_x[a + 1, j] - mass_x[a, j]) / hx
            out[1, a, j] = ((fu_z[a, j + 1] - fu_z[a, j]) / (hz * phi) - w * duz
                            + (fu_x[a + 1, j] - fu_x[a, j]) / (hx * phi) - u * dux)
            out[2, a, j] = ((fw_z[a, j + 1] - fw_z[a, j]) / (hz * phi) - w * dwz
                            + (fw_x[a + 1, j] - fw_x[a, j]) / (hx * phi) - u * dwx)


@njit(cache=True, error_model="numpy")
def rates(data, ghost, hx, hz, upwind, params, out):
    """Evolution rates (3, nx, nz) of (phi, u, w) on the whole grid into `out`: the patch
    kernel on the whole grid's patch (:func:`halo`)."""
    patch_rates(halo(data, ghost), hx, hz, upwind, params, out)
