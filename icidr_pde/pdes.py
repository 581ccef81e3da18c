"""The 1-D shear cell as a py-pde PDE, for any rheology of :mod:`icidr_pde.rheology`.

Non-dimensional equations (3.13)-(3.15) for mu(I),Phi(I) and (5.3)-(5.5) for iCIDR,
written with the momentum fluxes F_u = tau_xz and F_w = tau_zz - p:

.. math::
    \\partial_t \\phi = -\\partial_z(\\phi w), \\qquad
    \\partial_t u = \\frac{1}{\\phi}\\partial_z F_u - w \\partial_z u, \\qquad
    \\partial_t w = \\frac{1}{\\phi}\\partial_z F_w - w \\partial_z w,

on 0 < z < H with walls u(0) = 0, u(H) = V0, w(0) = w(H) = 0 (3.9).

Finite-volume discretization on py-pde's cell-centred grid (h = H/N):

* the fluxes are evaluated on the N + 1 cell faces from the compact differences
  (u_{i+1} - u_i)/h and the face average of phi (no central-of-central stencil, so
  no undamped checkerboard mode);
* phi is in conservative flux form; the face flux phi w vanishes at the walls because
  the Dirichlet ghost value of w is -w_edge, so the mass integral is conserved to
  round-off and phi needs no physical boundary condition (its zero-gradient ghost value
  only enters the wall stress);
* advection is first-order upwind (default, as the paper's first-order differences) or
  central;
* every wall enters through py-pde's ghost cells (``make_full_data_setter``).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import sparse
from pde import CartesianGrid, FieldCollection, ScalarField
from pde.backends import get_backend
from pde.pdes.base import PDEBase

from .rheology import Material, Rheology, get_rheology

__all__ = ["ShearCellBase", "ShearCellPDE", "ADVECTION_SCHEMES"]

ADVECTION_SCHEMES = ("upwind", "central")
_RHS_CACHE: dict = {}


def make_fd_rates(stress: Callable, compile_function: Callable, upwind: bool) -> Callable:
    """Build ``rates(phi_g, u_g, w_g, h, params) -> (3, N) array`` on ghost-padded data.

    The arrays carry one ghost cell at each end (length N + 2); `stress` is an
    element-wise kernel of :mod:`icidr_pde.rheology`.
    """

    def rates(phi_g, u_g, w_g, h, params):
        n = phi_g.shape[0] - 2
        # face values (N + 1 faces) from the two neighbouring cells
        phi_f = 0.5 * (phi_g[1:] + phi_g[:-1])
        w_f = 0.5 * (w_g[1:] + w_g[:-1])
        uz_f = (u_g[1:] - u_g[:-1]) / h
        wz_f = (w_g[1:] - w_g[:-1]) / h
        p, txz, tzz = stress(phi_f, uz_f, wz_f, params)
        fw = tzz - p
        if upwind:
            phi_up = np.where(w_f > 0, phi_g[:-1], phi_g[1:])
        else:
            phi_up = phi_f
        mass = phi_up * w_f
        phi = phi_g[1:-1]
        w = w_g[1:-1]
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

    if compile_function is None:
        return rates
    return compile_function(rates)


class ShearCellBase(PDEBase):
    """What every discretization of the shear cell shares: the rheology, the walls (3.9),
    state construction, the numpy rate and the validity checks the stiff solver asks for.

    Args:
        rheology: 'mui' (mu(I),Phi(I), (3.6), (3.8)) or 'icidr' ((4.12), (4.14)), or a
            :class:`~icidr_pde.rheology.Rheology` instance
        material: parameters of (2.10)-(2.11) (default: Table 1)
        V0: velocity of the top wall (1 in the scalings (3.12))
    """

    check_implementation = False  # the numba and numpy paths share one source

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0):
        super().__init__()
        self.rheology = get_rheology(rheology, material)
        if not np.isfinite(V0):
            raise ValueError(f"`V0` must be finite; got {V0}")
        self.V0 = float(V0)

    @property
    def material(self) -> Material:
        return self.rheology.material

    @staticmethod
    def make_grid(N: int, H: float = 30.0) -> CartesianGrid:
        """The grid CartesianGrid([[0, H]], N) holding N values per field."""
        if int(N) != N or N < 4:
            raise ValueError(f"`N` must be an integer >= 4; got {N}")
        if not (np.isfinite(H) and H > 0):
            raise ValueError(f"`H` must be > 0; got {H}")
        return CartesianGrid([[0.0, float(H)]], int(N))

    def check_grid(self, grid) -> None:
        if not isinstance(grid, CartesianGrid) or grid.num_axes != 1 or grid.periodic[0]:
            raise ValueError("`grid` must be a non-periodic 1-D CartesianGrid([[0, H]], N) "
                             f"(use {type(self).__name__}.make_grid)")

    def nodes(self, grid) -> np.ndarray:
        """Positions z of the unknowns."""
        raise NotImplementedError

    def make_state(self, grid: CartesianGrid, phi, u, w) -> FieldCollection:
        """FieldCollection of phi, u, w sampled at :meth:`nodes` from callables or arrays."""
        self.check_grid(grid)
        z = self.nodes(grid)
        fields = []
        for label, f in (("phi", phi), ("u", u), ("w", w)):
            data = f(z) if callable(f) else np.broadcast_to(np.asarray(f, float), z.shape)
            fields.append(ScalarField(grid, np.array(data, dtype=float), label=label))
        return FieldCollection(fields)

    def evolution_rate(self, state: FieldCollection, t: float = 0) -> FieldCollection:
        """Numpy evaluation of the right-hand side (same source as the numba one)."""
        rhs = self.make_evolution_rate(state, "numpy")
        result = state.copy(label="evolution rate")
        result.data[:] = rhs(state.data, t)
        return result

    def check_state(self, data: np.ndarray) -> str | None:
        """Reason why `data` is outside the inertial regime, or None if it is valid."""
        phi = data[0]
        if np.all(phi > 0) and np.all(phi < self.material.phi_c):
            return None
        return (f"phi left (0, phi_c) = (0, {self.material.phi_c}): "
                f"min {phi.min():.6g}, max {phi.max():.6g}")

    def validity_margins(self, data: np.ndarray) -> np.ndarray:
        """Distances of phi from the ends of (0, phi_c); both positive while valid."""
        phi = data[0]
        return np.array([phi.min(), self.material.phi_c - phi.max()])


class ShearCellPDE(ShearCellBase):
    """Gravity-free 1-D shear cell (3.1)-(3.3) closed by a rheology, finite volumes.

    Args:
        rheology, material, V0: as for :class:`ShearCellBase`
        advection: 'upwind' (first order) or 'central' (second order) for w d_z
    """

    def __init__(
        self,
        rheology: str | Rheology = "icidr",
        material: Material | None = None,
        *,
        V0: float = 1.0,
        advection: str = "upwind",
    ):
        super().__init__(rheology, material, V0=V0)
        if advection not in ADVECTION_SCHEMES:
            raise ValueError(f"`advection` must be one of {ADVECTION_SCHEMES}; got {advection!r}")
        self.advection = advection
        self.bc_phi = {"derivative": 0}
        self.bc_u = {"x-": {"value": 0.0}, "x+": {"value": self.V0}}
        self.bc_w = {"value": 0.0}

    @property
    def expression(self) -> str:
        return (f"shear cell ({self.rheology.name}, finite volumes): d_t phi = -d_z(phi w); "
                "d_t u = d_z tau_xz/phi - w d_z u; d_t w = d_z(tau_zz - p)/phi - w d_z w")

    def make_evolution_rate(self, state: FieldCollection, backend) -> Callable:
        """Return rhs(state_data, t) for the `numpy` or `numba` backend."""
        self.check_grid(state.grid)
        backend = get_backend(backend)
        key = (self.rheology, self.V0, self.advection, backend.name, state.grid.state_serialized)
        if key in _RHS_CACHE:  # numba compiles in seconds; reuse across PDE instances
            return _RHS_CACHE[key]
        grid = state.grid
        n = grid.shape[0]
        h = float(grid.discretization[0])
        params = self.material.params
        setters = [
            backend.make_full_data_setter(grid.get_boundary_conditions(bc))
            for bc in (self.bc_phi, self.bc_u, self.bc_w)
        ]
        set_phi, set_u, set_w = setters
        compile_function = None if backend.name == "numpy" else backend.compile_function
        kernels = self.rheology.kernels()
        stress = kernels.stress_numpy if compile_function is None else kernels.stress_array
        rates = make_fd_rates(stress, compile_function, self.advection == "upwind")

        def pde_rhs(state_data, t=0.0):
            phi_g = np.empty(n + 2)
            u_g = np.empty(n + 2)
            w_g = np.empty(n + 2)
            set_phi(phi_g, state_data[0])
            set_u(u_g, state_data[1])
            set_w(w_g, state_data[2])
            return rates(phi_g, u_g, w_g, h, params)

        if compile_function is not None:
            pde_rhs = compile_function(pde_rhs)
        _RHS_CACHE[key] = pde_rhs
        return pde_rhs

    # --- what the stiff integrator asks of a discretization ---------------------------

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

    def make_jacobian(self, state) -> Callable:
        """Analytic sparse Jacobian jac(t, y) of the flattened right-hand side."""
        self.check_grid(state.grid)
        return _fd_jacobian(self, state.grid.shape[0], float(state.grid.discretization[0]))

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """Face positions and (phi, u_z, w_z) on the faces, where the stresses live."""
        n, h = grid.shape[0], float(grid.discretization[0])
        phi_g, u_g, w_g = _ghost_padded(data, self.V0)
        z_f = np.linspace(grid.axes_bounds[0][0], grid.axes_bounds[0][1], n + 1)
        return (z_f, 0.5 * (phi_g[1:] + phi_g[:-1]), np.diff(u_g) / h, np.diff(w_g) / h)

    def nodes(self, grid) -> np.ndarray:
        """Positions z of the unknowns (cell centres)."""
        return grid.axes_coords[0]

    def integral(self, values: np.ndarray, grid) -> float:
        """Integral over 0 < z < H of cell-centred values (midpoint rule, exact for mass)."""
        return float(np.sum(values) * grid.discretization[0])



def _ghost_extension(n: int, sign_left: float, sign_right: float):
    """Sparse E with full = E @ valid + const for one ghost cell per side."""
    rows = np.concatenate(([0], np.arange(1, n + 1), [n + 1]))
    cols = np.concatenate(([0], np.arange(n), [n - 1]))
    vals = np.concatenate(([sign_left], np.ones(n), [sign_right]))
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
        rows = np.concatenate((i, i))
        cols = np.concatenate((i + shift, i + shift + 1))
        vals = np.concatenate((-np.ones(n), np.ones(n))) / h
    else:
        rows = np.concatenate((i, i))
        cols = np.concatenate((i, i + 2))
        vals = np.concatenate((-np.ones(n), np.ones(n))) / (2 * h)
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n, n + 2))


def _ghost_padded(data: np.ndarray, V0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """phi, u, w with the same ghost values the py-pde boundary conditions set."""
    phi, u, w = data
    phi_g = np.concatenate(([phi[0]], phi, [phi[-1]]))
    u_g = np.concatenate(([-u[0]], u, [2 * V0 - u[-1]]))
    w_g = np.concatenate(([-w[0]], w, [-w[-1]]))
    return phi_g, u_g, w_g


def _fd_jacobian(pde: "ShearCellPDE", n: int, h: float):
    """Analytic sparse Jacobian of the finite-volume right-hand side (chain rule)."""
    upwind = pde.advection == "upwind"
    rheology = pde.rheology
    E_phi = _ghost_extension(n, 1.0, 1.0)
    E_dir = _ghost_extension(n, -1.0, -1.0)
    avg, grad, div = _face_operators(n, h)
    A_phi, G_dir, A_dir = avg @ E_phi, grad @ E_dir, avg @ E_dir
    diag = sparse.diags

    def jacobian(t, y):
        data = y.reshape(3, n)
        phi, u, w = data
        phi_g, u_g, w_g = _ghost_padded(data, pde.V0)
        phi_f, w_f = avg @ phi_g, avg @ w_g
        uz_f, wz_f = grad @ u_g, grad @ w_g
        p, txz, tzz = rheology.stress(phi_f, uz_f, wz_f)
        d = rheology.stress_jacobian(phi_f, uz_f, wz_f)
        dfu = d[3:6]
        dfw = [d[6 + k] - d[k] for k in range(3)]
        inv_phi = diag(1 / phi)
        conv = _advection_operator(w, h, upwind)
        du, dw = conv @ u_g, conv @ w_g
        blocks_u, blocks_w = [], []
        for flux, dflux, blocks in ((txz, dfu, blocks_u), (tzz - p, dfw, blocks_w)):
            divf = div @ flux
            blocks.append(inv_phi @ div @ diag(dflux[0]) @ A_phi - diag(divf / phi**2))
            blocks.append(inv_phi @ div @ diag(dflux[1]) @ G_dir)
            blocks.append(inv_phi @ div @ diag(dflux[2]) @ G_dir)
        C = conv @ E_dir
        blocks_u[1] = blocks_u[1] - diag(w) @ C
        blocks_u[2] = blocks_u[2] - diag(du)
        blocks_w[2] = blocks_w[2] - diag(w) @ C - diag(dw)
        if upwind:
            up = sparse.csr_matrix(
                (np.ones(n + 1), (np.arange(n + 1), np.arange(n + 1) + (w_f <= 0))),
                shape=(n + 1, n + 2),
            )
            phi_up = up @ phi_g
        else:
            up, phi_up = avg, phi_f
        mass_phi = -div @ diag(w_f) @ up @ E_phi
        mass_w = -div @ diag(phi_up) @ A_dir
        return sparse.bmat(
            [[mass_phi, None, mass_w], blocks_u, blocks_w], format="csc"
        )

    return jacobian
