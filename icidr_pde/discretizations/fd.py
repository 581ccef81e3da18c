"""Finite volumes for the 1-D shear cell on py-pde's cell-centred grid (``fd``).

Non-dimensional equations (3.13)-(3.15) for mu(I),Phi(I) and (5.3)-(5.5) for iCIDR,
written with the momentum fluxes F_u = tau_xz and F_w = tau_zz - p:

.. math::
    \\partial_t \\phi = -\\partial_z(\\phi w), \\qquad
    \\partial_t u = \\frac{1}{\\phi}\\partial_z F_u - w \\partial_z u, \\qquad
    \\partial_t w = \\frac{1}{\\phi}\\partial_z F_w - w \\partial_z w,

on 0 < z < H with walls u(0) = 0, u(H) = V0, w(0) = w(H) = 0 (3.9); h = H/N:

* the fluxes are evaluated on the N + 1 cell faces from the compact differences
  (u_{i+1} - u_i)/h and the face average of phi (no central-of-central stencil, so
  no undamped checkerboard mode);
* phi is in conservative flux form; the face flux phi w vanishes at the walls because
  the Dirichlet ghost value of w is -w_edge, so the mass integral is conserved to
  round-off and phi needs no physical boundary condition (its zero-gradient ghost value
  only enters the wall stress);
* advection is first-order upwind (default, as the paper's first-order differences) or
  central;
* every wall enters through py-pde's ghost cells. The compiled kernel
  (``templates/fd.py``) and the analytic Jacobian take each ghost value as the affine map
  alpha * (edge value) + beta read off py-pde's boundary setter once per grid
  (:meth:`ShearCellPDE.ghost_coefficients`); the numpy path calls the setters themselves.
"""

from __future__ import annotations

import importlib.resources
from typing import Callable

import numpy as np
from pde import CartesianGrid, FieldCollection
from pde.backends import get_backend
from scipy import sparse

from ..rheology import Material, Rheology
from ..grid_size import FD
from ..rheology.codegen import compose, first_call
from .base import ShearCellBase

__all__ = ["ShearCellPDE", "ADVECTION_SCHEMES", "make_fd_rates"]

ADVECTION_SCHEMES = ("upwind", "central")
_TEMPLATE = importlib.resources.files(__package__).joinpath("templates", "fd.py").read_text()
_RHS_CACHE: dict = {}


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


class ShearCellPDE(ShearCellBase):
    """Gravity-free 1-D shear cell (3.1)-(3.3) closed by a rheology, finite volumes.

    Args:
        rheology, material, V0: as for :class:`~icidr_pde.discretizations.base.ShearCellBase`
        advection: 'upwind' (first order, default) or 'central' (second order) for w d_z
    """

    name = "fd"
    label = "finite volumes"
    default_N = 201
    options = {"advection": ADVECTION_SCHEMES}
    grid_limit = FD
    max_N = FD.max_N
    memory_note = FD.memory_note

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, advection: str = "upwind", **options):
        super().__init__(rheology, material, V0=V0, advection=advection, **options)
        self.bc_phi = {"derivative": 0}
        self.bc_u = {"x-": {"value": 0.0}, "x+": {"value": self.V0}}
        self.bc_w = {"value": 0.0}

    @property
    def expression(self) -> str:
        return (f"shear cell ({self.rheology.name}, finite volumes): d_t phi = -d_z(phi w); "
                "d_t u = d_z tau_xz/phi - w d_z u; d_t w = d_z(tau_zz - p)/phi - w d_z w")

    @staticmethod
    def _spacing(grid) -> tuple[int, float]:
        return int(grid.shape[0]), float(grid.discretization[0])

    # --- walls ---------------------------------------------------------------------------

    def _setters(self, grid, backend="numpy"):
        backend = get_backend(backend)
        return [backend.make_full_data_setter(grid.get_boundary_conditions(bc))
                for bc in (self.bc_phi, self.bc_u, self.bc_w)]

    def ghost_coefficients(self, grid) -> np.ndarray:
        """(3, 2, 2) array: ghost value of field k at side s (0: z = 0, 1: z = H) is
        ``c[k, s, 0] * edge + c[k, s, 1]``, read off py-pde's boundary setters.

        Raises if a setter is not affine in the edge value alone (then it cannot be used here).
        Memoised per grid (building py-pde's boundary setters costs ~4 ms, and the chi
        tracker asks at every interrupt through :meth:`strain_rates`).
        """
        cached = getattr(self, "_ghost_cache", None)
        if cached is not None and cached[0] == grid:
            return cached[1].copy()
        coeffs = self._ghost_coefficients(grid)
        self._ghost_cache = (grid, coeffs)
        return coeffs.copy()

    def _ghost_coefficients(self, grid) -> np.ndarray:
        n = grid.shape[0]
        coeffs = np.empty((3, 2, 2))
        for k, setter in enumerate(self._setters(grid)):
            def ghosts(valid):
                full = np.zeros(n + 2)
                setter(full, valid)
                return np.array([full[0], full[-1]])

            beta = ghosts(np.zeros(n))
            alpha = ghosts(np.ones(n)) - beta
            probe = np.linspace(0.3, 1.7, n)
            if not np.allclose(ghosts(probe), alpha * probe[[0, -1]] + beta, rtol=1e-14, atol=1e-14):
                raise ValueError(f"boundary condition of field {self.fields[k]!r} is not an affine "
                                 "function of the edge value")
            coeffs[k, :, 0], coeffs[k, :, 1] = alpha, beta
        return coeffs

    @staticmethod
    def _padded(data: np.ndarray, c: np.ndarray) -> np.ndarray:
        """(3, N + 2) data with the ghost values of the coefficients `c` (:meth:`ghost_coefficients`)."""
        g = np.empty((3, data.shape[1] + 2))
        g[:, 1:-1] = data
        g[:, 0] = c[:, 0, 0] * data[:, 0] + c[:, 0, 1]
        g[:, -1] = c[:, 1, 0] * data[:, -1] + c[:, 1, 1]
        return g

    # --- right-hand side -------------------------------------------------------------------

    def _loops(self):
        return compose(_TEMPLATE, self.rheology.kernels(self.kinematics), name="fd")

    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from the compiled finite-volume kernel (cached on disk)."""
        self.check_grid(state.grid)
        _, h = self._spacing(state.grid)
        loops = self._loops()
        kernel = loops.rates
        ghost = self.ghost_coefficients(state.grid)
        upwind = self.advection == "upwind"
        params = self.material.params

        def rhs(data, t=0.0):
            out = np.empty(data.shape)
            kernel(np.ascontiguousarray(data, dtype=float), ghost, h, upwind, params, out)
            return out

        first_call(loops, lambda: rhs(state.data), f"{self.rheology.name} on {self.name}")
        return rhs

    def make_evolution_rate(self, state: FieldCollection, backend="numpy") -> Callable:
        """rhs(state_data, t) for py-pde's `numpy` (independent numpy code, py-pde's
        boundary setters) or `numba` backend (the compiled kernel of :meth:`make_rates`)."""
        self.check_grid(state.grid)
        backend = get_backend(backend)
        n, h = self._spacing(state.grid)
        params = self.material.params
        if backend.name != "numpy":
            key = (self.rheology, self.V0, self.advection, state.grid.state_serialized)
            if key not in _RHS_CACHE:
                kernel, ghost = self._loops().rates, self.ghost_coefficients(state.grid)
                upwind = self.advection == "upwind"

                def pde_rhs(state_data, t=0.0):
                    out = np.empty(state_data.shape)
                    kernel(state_data, ghost, h, upwind, params, out)
                    return out

                _RHS_CACHE[key] = pde_rhs  # py-pde compiles this thin wrapper
            return _RHS_CACHE[key]
        set_phi, set_u, set_w = self._setters(state.grid)
        rates = make_fd_rates(self.rheology.kernels(self.kinematics).stress_numpy,
                              self.advection == "upwind")

        def numpy_rhs(state_data, t=0.0):
            phi_g, u_g, w_g = np.empty(n + 2), np.empty(n + 2), np.empty(n + 2)
            set_phi(phi_g, state_data[0])
            set_u(u_g, state_data[1])
            set_w(w_g, state_data[2])
            return rates(phi_g, u_g, w_g, h, params)

        return numpy_rhs

    # --- what the stiff integrator asks of a discretization ----------------------------------

    def jacobian_sparsity(self, state) -> sparse.csr_matrix:
        """Block-tridiagonal pattern of the Jacobian: every field couples to i-1, i, i+1."""
        n = state.grid.shape[0]
        tri = sparse.diags([1.0, 1.0, 1.0], [-1, 0, 1], shape=(n, n))
        return sparse.csr_matrix(sparse.bmat([[tri] * 3] * 3))

    def interleaving(self, state):
        """Ordering (phi_0, u_0, w_0, phi_1, ...) in which the Jacobian is banded.

        Returns the permutation `perm` (interleaved = flat[perm]) and the lower and upper
        bandwidths (5, 5): cell i couples to cells i - 1 .. i + 1.
        """
        n = state.grid.shape[0]
        perm = (np.arange(n)[:, None] + n * np.arange(3)[None, :]).ravel()
        return perm, 5, 5

    def make_band_jacobian(self, state) -> Callable:
        """jac_into(y, J): the analytic Jacobian in the ordering of :meth:`interleaving`
        (`y` interleaved), written by the compiled kernel into the band of the dense (3N, 3N)
        array `J` (entries outside the cells' 3 x 3 blocks are left untouched)."""
        self.check_grid(state.grid)
        n, h = self._spacing(state.grid)
        kernel = self._loops().jacobian_interleaved
        ghost = self.ghost_coefficients(state.grid)
        upwind = self.advection == "upwind"
        params = self.material.params

        def jac_into(y, J):  # a fresh C copy (CVODE's y is read-only): one compiled signature
            kernel(np.array(y, dtype=float).reshape(n, 3).T, ghost, h, upwind, params, J)

        # compile or load now, on 4 cells: the kernel's types, not a dense (3N, 3N) array
        probe = np.array(state.data[:, :4].T, dtype=float).reshape(4, 3).T  # jac_into's layout
        kernel(probe, ghost, h, upwind, params, np.zeros((12, 12)))
        return jac_into

    def make_jacobian(self, state) -> Callable:
        """Analytic sparse Jacobian jac(t, y) of the flattened right-hand side."""
        self.check_grid(state.grid)
        return _fd_jacobian(self, state.grid)

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """Face positions and (phi, u_z, w_z) on the faces, where the stresses live."""
        n, h = self._spacing(grid)
        phi_g, u_g, w_g = self._padded(np.asarray(data, float), self.ghost_coefficients(grid))
        z_f = np.linspace(grid.axes_bounds[0][0], grid.axes_bounds[0][1], n + 1)
        return (z_f, 0.5 * (phi_g[1:] + phi_g[:-1]), np.diff(u_g) / h, np.diff(w_g) / h)

    def nodes(self, grid) -> np.ndarray:
        """Positions z of the unknowns (cell centres)."""
        return grid.axes_coords[0]

    def integral(self, values: np.ndarray, grid) -> float:
        """Integral over 0 < z < H of cell-centred values (midpoint rule, exact for mass)."""
        return float(np.sum(values) * grid.discretization[0])

    def quadrature_weights(self, grid) -> np.ndarray:
        """Weights c of :meth:`integral` (integral = c . values)."""
        return np.full(grid.shape[0], float(grid.discretization[0]))


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


def _fd_jacobian(pde: ShearCellPDE, grid: CartesianGrid):
    """Analytic sparse Jacobian of the finite-volume right-hand side (chain rule).

    The wall rows come from the same ghost-cell maps as the right-hand side: d(ghost)/d(edge)
    is the alpha of :meth:`ShearCellPDE.ghost_coefficients`.
    """
    n, h = pde._spacing(grid)
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
        phi_g, u_g, w_g = pde._padded(data, coeffs)
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
