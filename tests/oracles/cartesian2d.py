"""Finite volumes of the 2-D x-periodic shear cell in numpy, written independently of the compiled
kernels (``templates/cartesian2d.py``), on the ghost cells of py-pde's own boundary setters: the
oracle the contract tests compare them with."""

import numpy as np

__all__ = ["numpy_rates", "numpy_rhs"]


def numpy_rates(g, hx, hz, upwind, stress, params):
    """Rates from z-padded data g (3, Nx, Nz + 2); x-neighbours by periodic rolls."""
    phi_g, u_g, w_g = g

    def xp(a):  # value at i + 1
        return np.roll(a, -1, axis=0)

    def xm(a):  # value at i - 1
        return np.roll(a, 1, axis=0)

    def zavg(a):
        return 0.5 * (a[:, 1:] + a[:, :-1])

    # z-faces
    phi_fz, w_fz = zavg(phi_g), zavg(w_g)
    ux_z = zavg((xp(u_g) - xm(u_g)) / (2 * hx))
    wx_z = zavg((xp(w_g) - xm(w_g)) / (2 * hx))
    uz_z = np.diff(u_g, axis=1) / hz
    wz_z = np.diff(w_g, axis=1) / hz
    p, txx, txz, tzz = stress(phi_fz, ux_z, uz_z, wx_z, wz_z, params)
    fu_z, fw_z = txz, tzz - p
    mass_z = (np.where(w_fz > 0, phi_g[:, :-1], phi_g[:, 1:]) if upwind else phi_fz) * w_fz
    # x-faces (between i and i + 1), interior rows
    phi, u, w = phi_g[:, 1:-1], u_g[:, 1:-1], w_g[:, 1:-1]
    phi_fx, u_fx = 0.5 * (phi + xp(phi)), 0.5 * (u + xp(u))
    ux_x, wx_x = (xp(u) - u) / hx, (xp(w) - w) / hx
    cz_u = (u_g[:, 2:] - u_g[:, :-2]) / (2 * hz)
    cz_w = (w_g[:, 2:] - w_g[:, :-2]) / (2 * hz)
    uz_x, wz_x = 0.5 * (cz_u + xp(cz_u)), 0.5 * (cz_w + xp(cz_w))
    p, txx, txz, tzz = stress(phi_fx, ux_x, uz_x, wx_x, wz_x, params)
    fu_x, fw_x = txx - p, txz
    mass_x = (np.where(u_fx > 0, phi, xp(phi)) if upwind else phi_fx) * u_fx
    if upwind:
        back_z = lambda a: (a[:, 1:-1] - a[:, :-2]) / hz  # noqa: E731
        fwd_z = lambda a: (a[:, 2:] - a[:, 1:-1]) / hz  # noqa: E731
        duz = np.where(w > 0, back_z(u_g), fwd_z(u_g))
        dwz = np.where(w > 0, back_z(w_g), fwd_z(w_g))
        dux = np.where(u > 0, (u - xm(u)) / hx, (xp(u) - u) / hx)
        dwx = np.where(u > 0, (w - xm(w)) / hx, (xp(w) - w) / hx)
    else:
        duz, dwz = cz_u, cz_w
        dux, dwx = (xp(u) - xm(u)) / (2 * hx), (xp(w) - xm(w)) / (2 * hx)
    out = np.empty((3,) + phi.shape)
    out[0] = -np.diff(mass_z, axis=1) / hz - (mass_x - xm(mass_x)) / hx
    out[1] = np.diff(fu_z, axis=1) / (hz * phi) - w * duz + (fu_x - xm(fu_x)) / (hx * phi) - u * dux
    out[2] = np.diff(fw_z, axis=1) / (hz * phi) - w * dwz + (fw_x - xm(fw_x)) / (hx * phi) - u * dwx
    return out


def numpy_rhs(pde, grid):
    """rhs(data, t) of the 2-D scheme in numpy, the walls by py-pde's boundary setters."""
    setters = pde._setters(grid)
    nx, nz, hx, hz = pde._spacing(grid)
    stress = pde._law().stress_numpy
    params = pde.material.params
    upwind = pde.advection == "upwind"

    def rhs(state_data, t=0.0):
        g = np.empty((3, nx, nz + 2))
        for k, setter in enumerate(setters):
            full = np.empty((nx + 2, nz + 2))
            setter(full, state_data[k])
            g[k] = full[1:-1]
        return numpy_rates(g, hx, hz, upwind, stress, params)

    return rhs
