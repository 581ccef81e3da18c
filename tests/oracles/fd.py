"""Finite volumes of the shear cell in numpy, written independently of the compiled kernels
(``templates/fd.py``): the oracle the contract tests compare them with. The walls are py-pde's
own boundary setters (:func:`numpy_rhs`), or their affine maps (:func:`fd_jacobian`)."""

from typing import Callable

import numpy as np
from pde.backends import get_backend
from scipy import sparse

__all__ = ["make_fd_rates", "numpy_rhs", "fd_jacobian"]


def make_fd_rates(stress: Callable, upwind: bool) -> Callable:
    """Numpy ``rates(phi_g, u_g, w_g, h, params) -> (3, N) array`` on ghost-padded data.

    The arrays carry one ghost cell at each end (length N + 2); `stress` is the numpy
    kernel of the rheology (``rheology.kernels().stress_numpy``).
    """

    def rates(phi_g, u_g, w_g, h, params):
        n = phi_g.shape[0] - 2
        phi_f = 0.5 * (phi_g[1:] + phi_g[:-1])
        w_f = 0.5 * (w_g[1:] + w_g[:-1])
        uz_f = (u_g[1:] - u_g[:-1]) / h
        wz_f = (w_g[1:] - w_g[:-1]) / h
        p, txz, tzz = stress(phi_f, uz_f, wz_f, params)
        fw = tzz - p
        phi_up = np.where(w_f > 0, phi_g[:-1], phi_g[1:]) if upwind else phi_f
        mass = phi_up * w_f
        phi, w = phi_g[1:-1], w_g[1:-1]
        if upwind:
            du = np.where(w > 0, u_g[1:-1] - u_g[:-2], u_g[2:] - u_g[1:-1]) / h
            dw = np.where(w > 0, w_g[1:-1] - w_g[:-2], w_g[2:] - w_g[1:-1]) / h
        else:
            du = (u_g[2:] - u_g[:-2]) / (2 * h)
            dw = (w_g[2:] - w_g[:-2]) / (2 * h)
        out = np.empty((3, n))
        out[0] = -(mass[1:] - mass[:-1]) / h
        out[1] = (txz[1:] - txz[:-1]) / (h * phi) - w * du
        out[2] = (fw[1:] - fw[:-1]) / (h * phi) - w * dw
        return out

    return rates


def _setters(pde, grid):
    backend = get_backend("numpy")
    return [backend.make_full_data_setter(grid.get_boundary_conditions(bc))
            for bc in (pde.bc_phi, pde.bc_u, pde.bc_w)]


def setter_ghost_coefficients(pde, grid) -> np.ndarray:
    """(3, 2, 2) ghost maps read off py-pde's boundary setters: ghost = alpha * edge + beta."""
    n = grid.shape[0]
    coeffs = np.empty((3, 2, 2))
    for k, setter in enumerate(_setters(pde, grid)):
        def ghosts(valid):
            full = np.zeros(n + 2)
            setter(full, valid)
            return np.array([full[0], full[-1]])

        beta = ghosts(np.zeros(n))
        alpha = ghosts(np.ones(n)) - beta
        probe = np.linspace(0.3, 1.7, n)
        assert np.allclose(ghosts(probe), alpha * probe[[0, -1]] + beta, rtol=1e-14, atol=1e-14)
        coeffs[k, :, 0], coeffs[k, :, 1] = alpha, beta
    return coeffs


def numpy_rhs(pde, grid):
    """rhs(data, t) of the finite-volume scheme in numpy, walls by py-pde's setters."""
    n, h = int(grid.shape[0]), float(grid.discretization[0])
    set_phi, set_u, set_w = _setters(pde, grid)
    rates = make_fd_rates(pde.rheology.kernels(pde.kinematics).stress_numpy, pde.advection == "upwind")
    params = pde.material.params

    def rhs(state_data, t=0.0):
        phi_g, u_g, w_g = np.empty(n + 2), np.empty(n + 2), np.empty(n + 2)
        set_phi(phi_g, state_data[0])
        set_u(u_g, state_data[1])
        set_w(w_g, state_data[2])
        return rates(phi_g, u_g, w_g, h, params)

    return rhs


def _padded(data, c):
    g = np.empty((3, data.shape[1] + 2))
    g[:, 1:-1] = data
    g[:, 0] = c[:, 0, 0] * data[:, 0] + c[:, 0, 1]
    g[:, -1] = c[:, 1, 0] * data[:, -1] + c[:, 1, 1]
    return g


def _ghost_extension(n: int, alpha_left: float, alpha_right: float):
    """Sparse E with full = E @ valid + const for one ghost cell per side."""
    rows = np.concatenate(([0], np.arange(1, n + 1), [n + 1]))
    cols = np.concatenate(([0], np.arange(n), [n - 1]))
    vals = np.concatenate(([alpha_left], np.ones(n), [alpha_right]))
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n + 2, n))


def _face_operators(n: int, h: float):
    """Face average and face gradient (faces x full) and divergence (cells x faces)."""
    avg = sparse.diags([0.5, 0.5], [0, 1], shape=(n + 1, n + 2), format="csr")
    grad = sparse.diags([-1 / h, 1 / h], [0, 1], shape=(n + 1, n + 2), format="csr")
    div = sparse.diags([-1 / h, 1 / h], [0, 1], shape=(n, n + 1), format="csr")
    return avg, grad, div


def _advection_operator(w: np.ndarray, h: float, upwind: bool):
    """Cells x full matrix of d_z (upwind with the sign of w, or central)."""
    n = w.size
    i = np.arange(n)
    if upwind:
        shift = np.where(w > 0, 0, 1)
        cols = np.concatenate((i + shift, i + shift + 1))
        vals = np.concatenate((-np.ones(n), np.ones(n))) / h
    else:
        cols = np.concatenate((i, i + 2))
        vals = np.concatenate((-np.ones(n), np.ones(n))) / (2 * h)
    return sparse.csr_matrix((vals, (np.concatenate((i, i)), cols)), shape=(n, n + 2))


def fd_jacobian(pde, grid):
    """Analytic sparse Jacobian of the finite-volume right-hand side (chain rule).

    The wall rows come from the same ghost-cell maps as the right-hand side: d(ghost)/d(edge)
    is the alpha of :meth:`ShearCellPDE.ghost_coefficients`.
    """
    n, h = int(grid.shape[0]), float(grid.discretization[0])
    upwind = pde.advection == "upwind"
    rheology = pde.rheology
    coeffs = pde.ghost_coefficients(grid)
    alpha = coeffs[:, :, 0]
    E_phi, E_u, E_w = (_ghost_extension(n, *alpha[k]) for k in range(3))
    avg, grad, div = _face_operators(n, h)
    A_phi, G_u, G_w, A_w = avg @ E_phi, grad @ E_u, grad @ E_w, avg @ E_w
    diag = sparse.diags

    def jacobian(t, y):
        data = y.reshape(3, n)
        phi, u, w = data
        phi_g, u_g, w_g = _padded(data, coeffs)
        phi_f, w_f = avg @ phi_g, avg @ w_g
        uz_f, wz_f = grad @ u_g, grad @ w_g
        # the kernels themselves: the public stress() refuses results outside the float range
        kernels, params = rheology.kernels(), rheology.material.params
        p, txz, tzz = kernels.stress_numpy(phi_f, uz_f, wz_f, params)
        d = kernels.stress_jacobian_numpy(phi_f, uz_f, wz_f, params)
        dfu = d[3:6]
        dfw = [d[6 + k] - d[k] for k in range(3)]
        inv_phi = diag(1 / phi)
        conv = _advection_operator(w, h, upwind)
        du, dw = conv @ u_g, conv @ w_g
        blocks_u, blocks_w = [], []
        for flux, dflux, blocks in ((txz, dfu, blocks_u), (tzz - p, dfw, blocks_w)):
            divf = div @ flux
            blocks.append(inv_phi @ div @ diag(dflux[0]) @ A_phi - diag(divf / phi**2))
            blocks.append(inv_phi @ div @ diag(dflux[1]) @ G_u)
            blocks.append(inv_phi @ div @ diag(dflux[2]) @ G_w)
        blocks_u[1] = blocks_u[1] - diag(w) @ conv @ E_u
        blocks_u[2] = blocks_u[2] - diag(du)
        blocks_w[2] = blocks_w[2] - diag(w) @ conv @ E_w - diag(dw)
        if upwind:
            up = sparse.csr_matrix(
                (np.ones(n + 1), (np.arange(n + 1), np.arange(n + 1) + (w_f <= 0))),
                shape=(n + 1, n + 2),
            )
            phi_up = up @ phi_g
        else:
            up, phi_up = avg, phi_f
        mass_phi = -div @ diag(w_f) @ up @ E_phi
        mass_w = -div @ diag(phi_up) @ A_w
        return sparse.bmat([[mass_phi, None, mass_w], blocks_u, blocks_w], format="csc")

    return jacobian
