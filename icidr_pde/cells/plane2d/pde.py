"""Finite volumes for the 2-D x-periodic shear cell on py-pde's Cartesian grid (``fv2d``).

The 2-D equations (2.1)-(2.3) with rho = rho_* phi, gravity-free, non-dimensional (3.12),
sigma = -p I + tau with tau = c S from the rheology's (p, c) on invariants (2.6):

.. math::
    \\partial_t \\phi = -\\nabla\\cdot(\\phi \\mathbf{u}), \\qquad
    \\partial_t \\mathbf{u} = \\frac{1}{\\phi}\\nabla\\cdot\\sigma - (\\mathbf{u}\\cdot\\nabla)\\mathbf{u},

on 0 <= x < L (periodic) and 0 < z < H with walls u = w = 0 at z = 0 and u = V0, w = 0
at z = H (3.9), fields phi, u, w on ``CartesianGrid([[0, L], [0, H]], [Nx, Nz],
periodic=[True, False])`` (cell centres, hx = L/Nx, hz = H/Nz). The scheme is the 1-D
finite-volume scheme (:mod:`.fd`) in both directions:

* the full stress tensor (sigma_xx, sigma_xz, sigma_zz) is evaluated on every cell face,
  from the face average of phi, the compact difference normal to the face and the average
  of the tangential central differences of the four adjacent cells (no central-of-central
  stencil in the normal direction, so no undamped checkerboard);
* phi is in conservative flux form div(phi u) with central (default, second order) or
  first-order upwind face values; the wall mass flux vanishes (Dirichlet ghost value of w is -w_edge), and
  the x-fluxes telescope on the periodic axis, so the mass integral is conserved to
  round-off;
* advection (u.grad) u is central (default) or first-order upwind per direction. Central is
  the default in 2-D: on iCIDR bump2d it converges at order 2 without oscillating (the
  stress divergence damps the grid scale; docs/sim2d.md), where upwind is first order
  (20 % off at 64^2). The 1-D default stays upwind, the paper's differences;
* the walls enter through py-pde's boundary handling: the ghost rows are the affine maps
  alpha * (edge value) + beta read off py-pde's boundary setters once per grid
  (:meth:`ShearCell2DPDE.ghost_coefficients`); the numpy oracle of the tests calls the setters themselves.

With x-independent data every x-difference vanishes and the z-fluxes are those of the 1-D
scheme: the rates equal the 1-D finite-volume rates up to the round-off of the 2-D stress
kernel (tested). The Jacobian is analytic: the chain rule through the face stencils
(sparse linear operators built once per patch shape) with the generated kernels' exact partial
derivatives; its pattern (every cell couples to its 3 x 3 neighbourhood) is fixed, so a
sparse direct solver can reuse its symbolic factorisation.

Rates and Jacobian are written once, on a *patch*: a block of cells with one ghost layer
(:class:`Patches`). The whole grid is the patch whose x ghosts are the periodic columns and
whose z ghosts the walls' rows; a block of a distributed grid (PETSc's DMDA) is a patch whose
ghosts come from the neighbouring blocks, so each process evaluates its own cells alone.
"""

from __future__ import annotations

import importlib.resources
from dataclasses import dataclass
from typing import Callable

import numpy as np
from pde import CartesianGrid, FieldCollection
from pde.backends import get_backend
from scipy import sparse

from . import core
from .core import THIN_CELL, grid_shape, measures
from ...discretizations.grid_size import PLANE2D
from ...discretizations.registry import ADVECTION_SCHEMES_2D
from ...rheology import PLANE_FLOW, Material, Rheology
from ...rheology.codegen import compose
from ...discretizations.base import ShearCellBase
from .cell import Plane2D


__all__ = ["ShearCell2DPDE", "Patches", "measures", "THIN_CELL"]

_TEMPLATE = importlib.resources.files(__package__).joinpath("templates", "plane2d.py").read_text()


@dataclass(frozen=True)
class Patches:
    """The scheme's right-hand side on patches of the grid, for an engine that distributes the
    grid by blocks of cells (PETSc's DMDA: periodic in x, walls in z, `dof` fields interleaved,
    a box stencil of width `stencil`).

    ``rates(g, low, high, out)``: g (dof, mx + 2, mz + 2) is a block of mx x mz cells with one
    ghost layer (x ghosts from the neighbouring block or the periodic image, z ghosts from the
    neighbouring block); where the block touches the wall z = 0 (`low`) or z = H (`high`) the
    ghost row is filled here from the walls' conditions. The rates of the block's cells go
    into out (dof, mx, mz): exactly the whole grid's rates on those cells (the whole grid is
    evaluated by the same kernel, as one patch). The engine's vector (no permutation) is the
    state data (dof, nx, nz) flattened.

    ``jacobian(g, low, high)``: the Jacobian of those rates (rows: the block's cells, data
    order (dof, mx, mz) flattened) by the patch's values (columns: g's (dof, mx + 2, mz + 2)
    flattened), a sparse CSR matrix; a wall's ghost row is a function of the edge row, so its
    columns are folded into the edge row's and are empty. These are the whole grid's
    Jacobian rows of the block's cells, to round-off.

    ``inside(a)``: whether a block's values a (its cells' `dof` values cell by cell, as a
    DMDA rank holds them) are finite with phi (field 0) inside its range: the scheme's check
    of a state, true or false, on each rank's own cells (None: the engine checks the whole
    state). `measured`: the field whose largest |value| is a run's series (w: max|w|).
    """

    shape: tuple[int, int]
    rates: Callable
    jacobian: Callable | None = None
    dof: int = 3
    periodic: tuple[bool, bool] = (True, False)
    stencil: int = 1
    inside: Callable | None = None
    measured: int = 2


def _takes_two(f) -> bool:
    """True if f can be called as f(x, z) (not only f(nodes))."""
    import inspect

    try:
        inspect.signature(f).bind(0, 0)
    except TypeError:
        return False
    except ValueError:  # no signature (a builtin, a numpy ufunc): as f(x, z)
        return True
    return True


class ShearCell2DPDE(ShearCellBase):
    """Gravity-free 2-D shear cell, x-periodic, closed by a rheology; finite volumes.

    Args:
        rheology, material, V0: as for the 1-D schemes
        advection: 'central' (second order, default) or 'upwind' (first order) for div(phi u) and (u.grad) u
    """

    name = "fv2d"
    #: the cell it discretizes (the names of its grid, its Jacobian structure: :mod:`icidr_pde.cells`)
    cell = Plane2D.registered()
    label = "finite volumes, 2-D"
    default_N = 64
    options = {"advection": ADVECTION_SCHEMES_2D}
    kinematics = PLANE_FLOW
    dim = 2
    #: waves advected along the periodic x: eigenvalues near the imaginary axis (engines.choose.time_order)
    advected_waves = True
    grid_limit = PLANE2D
    max_N = PLANE2D.max_N
    memory_note = PLANE2D.memory_note
    memory_estimate = staticmethod(PLANE2D.memory_estimate)

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, advection: str = "central", **options):
        super().__init__(rheology, material, V0=V0, advection=advection, **options)
        # x is periodic; the walls z = 0, H are py-pde's axis "y"
        self.bc_phi = {"x": "periodic", "y": {"derivative": 0}}
        self.bc_u = {"x": "periodic", "y-": {"value": 0.0}, "y+": {"value": self.V0}}
        self.bc_w = {"x": "periodic", "y": {"value": 0.0}}

    @property
    def expression(self) -> str:
        return (f"2-D shear cell ({self.rheology.name}, finite volumes): d_t phi = -div(phi u); "
                "d_t u = div(sigma)/phi - (u.grad) u")

    # --- grid and state -------------------------------------------------------------------

    @classmethod
    def make_grid(cls, N=None, H: float = 30.0, *, L: float | None = None, Nx: int | None = None,
                  Nz: int | None = None) -> CartesianGrid:
        """CartesianGrid([[0, L], [0, H]], [Nx, Nz], periodic=[True, False]).

        `N` is Nz (an int) or (Nx, Nz); explicit `Nx`, `Nz` win; Nx defaults to Nz and L to H
        (:func:`.core.grid_shape`).
        """
        Nx, Nz, L = grid_shape(N, H, L=L, Nx=Nx, Nz=Nz, default_N=cls.default_N)
        return CartesianGrid([[0.0, float(L)], [0.0, float(H)]], [int(Nx), int(Nz)],
                             periodic=[True, False])

    def check_grid(self, grid) -> None:
        if (not isinstance(grid, CartesianGrid) or grid.num_axes != 2
                or tuple(grid.periodic) != (True, False)):
            raise ValueError("`grid` must be a 2-D CartesianGrid([[0, L], [0, H]], [Nx, Nz], "
                             f"periodic=[True, False]) (use {type(self).__name__}.make_grid)")

    def nodes(self, grid, block=None) -> np.ndarray:
        """Cell centres, shape (Nx, Nz, 2): nodes[..., 0] = x, nodes[..., 1] = z; of the cells
        xs:xe, zs:ze alone where `block` is ((xs, xe), (zs, ze)) (a rank's block of a distributed
        grid, without the whole grid's)."""
        if block is None:
            return grid.cell_coords
        (xs, xe), (zs, ze) = block
        x, z = grid.axes_coords
        return np.stack(np.meshgrid(x[xs:xe], z[zs:ze], indexing="ij"), -1)

    def make_state(self, grid: CartesianGrid, phi, u, w) -> FieldCollection:
        """FieldCollection of phi, u, w, each a number, an array (Nx, Nz), a callable f(x, z) of
        the cell centres' coordinates (arrays (Nx, Nz); the 1-D class calls f(z)) or a py-pde
        expression in x and z (e.g. ``"z / 30 + 0.01 * sin(2 * pi * x / 30)"``). A callable of
        one argument gets the nodes (Nx, Nz, 2), as before."""
        from pde import ScalarField

        self.check_grid(grid)
        x, z = np.moveaxis(self.nodes(grid), -1, 0)
        fields = []
        for label, f in zip(("phi", "u", "w"), (phi, u, w)):
            if isinstance(f, str):  # py-pde's expressions import sympy: only where one is given
                from pde.tools.expressions import ScalarExpression

                f = ScalarExpression(f, signature=["x", "z"])
            data = (f(x, z) if _takes_two(f) else f(self.nodes(grid))) if callable(f) else np.asarray(f, float)
            fields.append(ScalarField(grid, np.array(np.broadcast_to(data, grid.shape), dtype=float), label=label))
        return FieldCollection(fields)

    def integral(self, values: np.ndarray, grid) -> float:
        """Integral over the cell of cell-centred values (midpoint rule, exact for mass)."""
        hx, hz = grid.discretization
        return float(np.sum(values) * hx * hz)

    @staticmethod
    def _spacing(grid) -> tuple[int, int, float, float]:
        nx, nz = grid.shape
        hx, hz = grid.discretization
        return int(nx), int(nz), float(hx), float(hz)

    # --- walls ---------------------------------------------------------------------------

    def _setters(self, grid, backend="numpy"):
        backend = get_backend(backend)
        return [backend.make_full_data_setter(grid.get_boundary_conditions(bc))
                for bc in (self.bc_phi, self.bc_u, self.bc_w)]

    def ghost_coefficients(self, grid) -> np.ndarray:
        """(3, 2, 2) array: the ghost value of field k beyond wall s (0: z = 0, 1: z = H)
        is ``c[k, s, 0] * edge + c[k, s, 1]``, read off py-pde's boundary setters.

        Raises if a setter is not affine in the edge value alone or depends on x.
        """
        nx, nz = grid.shape
        coeffs = np.empty((3, 2, 2))
        for k, setter in enumerate(self._setters(grid)):
            def ghosts(valid):
                full = np.zeros((nx + 2, nz + 2))
                setter(full, valid)
                return np.stack([full[1:-1, 0], full[1:-1, -1]])  # (2, nx)

            beta = ghosts(np.zeros((nx, nz)))
            alpha = ghosts(np.ones((nx, nz))) - beta
            probe = np.add.outer(np.linspace(0.3, 1.1, nx), np.linspace(0.2, 0.6, nz))
            edge = np.stack([probe[:, 0], probe[:, -1]])
            if not (np.allclose(ghosts(probe), alpha * edge + beta, rtol=1e-14, atol=1e-14)
                    and np.ptp(alpha, axis=1).max() == 0 and np.ptp(beta, axis=1).max() == 0):
                raise ValueError(f"boundary condition of field {('phi', 'u', 'w')[k]!r} is not an "
                                 "x-independent affine function of the edge value")
            coeffs[k, :, 0], coeffs[k, :, 1] = alpha[:, 0], beta[:, 0]
        return coeffs

    # --- right-hand side -------------------------------------------------------------------

    def _law(self):
        return self.rheology.kernels(self.kinematics)

    def _loops(self):
        return compose(_TEMPLATE, self._law(), name="plane2d")

    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from the compiled finite-volume kernel (cached on disk)."""
        self.check_grid(state.grid)
        _, _, hx, hz = self._spacing(state.grid)
        kernel = self._loops().rates
        ghost = self.ghost_coefficients(state.grid)
        upwind = self.advection == "upwind"
        params = self.material.params

        def rhs(data, t=0.0):
            out = np.empty(data.shape)
            kernel(np.ascontiguousarray(data, dtype=float), ghost, hx, hz, upwind, params, out)
            return out

        return rhs

    def make_evolution_rate(self, state: FieldCollection, backend="numpy") -> Callable:
        """rhs(state_data, t) for any py-pde backend: the kernel of :meth:`make_rates`, for `numba`
        in a thin wrapper py-pde compiles (the independent numpy implementation is the tests'
        oracle, tests/oracles/cartesian2d.py)."""
        self.check_grid(state.grid)
        if get_backend(backend).name == "numpy":
            return self.make_rates(state)
        kernel, ghost = self._loops().rates, self.ghost_coefficients(state.grid)
        _, _, hx, hz = self._spacing(state.grid)
        upwind, params = self.advection == "upwind", self.material.params

        def pde_rhs(state_data, t=0.0):  # py-pde compiles this thin wrapper
            out = np.empty(state_data.shape)
            kernel(state_data, ghost, hx, hz, upwind, params, out)
            return out

        return pde_rhs

    def patches(self, state: FieldCollection | None = None, *, grid=None) -> Patches:
        """The right-hand side on blocks of cells with one ghost layer (:class:`Patches`): the
        compiled patch kernel of :meth:`make_rates`, the walls' ghost rows filled first. Of the
        grid of `state`, or of `grid` (no state: a distributed run has none of the whole grid)."""
        grid = state.grid if grid is None else grid
        self.check_grid(grid)
        nx, nz, hx, hz = self._spacing(grid)
        loops = self._loops()
        walls, patch_rates = loops.walls, loops.patch_rates
        ghost = self.ghost_coefficients(grid)
        upwind, params = self.advection == "upwind", self.material.params

        patch = _PatchJacobian(self._law(), params, upwind, hx, hz)
        folds = {}

        def rates(g, low, high, out):
            walls(g, ghost, low, high)
            patch_rates(g, hx, hz, upwind, params, out)

        def jacobian(g, low, high):
            walls(g, ghost, low, high)
            key = g.shape[1:] + (bool(low), bool(high))
            if key not in folds:
                folds[key] = _wall_fold(g.shape[1] - 2, g.shape[2] - 2, ghost, low, high)
            return patch.matrix(g) @ folds[key]

        return Patches((nx, nz), rates, jacobian)

    # --- what the stiff integrator asks ------------------------------------------------------

    def jacobian_sparsity(self, state) -> sparse.csc_matrix:
        """Pattern of the Jacobian: every field of cell (i, j) couples to every field of the
        3 x 3 cells around it (periodic in x, folded onto the edge row at the walls)."""
        self.check_grid(state.grid)
        return _pattern(*state.grid.shape)

    def is_thin(self, grid) -> bool:
        """Whether the cells of `grid` are thin (hx > THIN_CELL hz): the Krylov solves of the py-pde
        path are then preconditioned along z (:meth:`line_pattern`)."""
        self.check_grid(grid)
        nx, nz = grid.shape
        L, H = (float(np.diff(b)[0]) for b in grid.axes_bounds)
        return core.thin_cell(nx, nz, L, H)

    def line_pattern(self, state) -> sparse.csc_matrix | None:
        """The part of :meth:`jacobian_sparsity` along z in a thin cell (hx > THIN_CELL hz), else
        None: every field of cell (i, j) and of cells (i, j +- 1), the couplings within each x
        column. A Newton matrix I - gamma J restricted to it is Nx independent banded systems,
        the preconditioner of the Krylov solves along the stiff direction of a thin cell.
        Measured, iCIDR bump2d 32^2, L = 30, t_end = 5, CVODE + GMRES(20) without/with it:
        H = 30: 138/221 steps (64^2), H = 3: 258/297, H = 0.3: 2814/156, H = 0.01: failed at
        t = 2e-3/97 steps."""
        if not self.is_thin(state.grid):
            return None
        nx, nz = state.grid.shape
        cz = sparse.diags([1.0, 1.0, 1.0], [-1, 0, 1], shape=(nz, nz))
        P = sparse.csc_matrix(sparse.kron(np.ones((3, 3)), sparse.kron(sparse.identity(nx), cz)))
        P.sort_indices()
        return P

    def interleaving(self, state):
        """None: the periodic axis leaves no narrow band (a sparse solver is used instead)."""
        return None

    def make_jacobian(self, state) -> Callable:
        """Analytic sparse Jacobian jac(t, y) of the flattened right-hand side (CSC)."""
        self.check_grid(state.grid)
        return _Jacobian2D(self, state.grid)

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """Face centres (n_faces, 2) and (phi, u_x, u_z, w_x, w_z) on them, where the stresses
        live: the z-faces (Nx (Nz + 1)), then the x-faces (Nx Nz)."""
        nx, nz, hx, hz = self._spacing(grid)
        ops = _Operators(nx, nz, hx, hz)
        g = self._loops().halo(np.ascontiguousarray(data, dtype=float), self.ghost_coefficients(grid)).reshape(3, -1)
        (lx, hx_), (lz, hz_) = grid.axes_bounds[0], grid.axes_bounds[1]
        x_c, z_c = grid.axes_coords
        x_f = np.linspace(lx, hx_, nx + 1)[1:]
        z_f = np.linspace(lz, hz_, nz + 1)
        pos_z = np.stack(np.meshgrid(x_c, z_f, indexing="ij"), -1).reshape(-1, 2)
        pos_x = np.stack(np.meshgrid(x_f, z_c, indexing="ij"), -1).reshape(-1, 2)
        qz, qx = ops.face_inputs(g)
        qx = tuple(a[nz:] for a in qx)  # x-face 0 (x = 0) is x-face Nx (x = L), the periodic image
        return (np.concatenate([pos_z, pos_x]),) + tuple(np.concatenate([a, b]) for a, b in zip(qz, qx))


# --- analytic Jacobian ---------------------------------------------------------------------


def _circulant(n: int, offsets, values) -> sparse.csr_matrix:
    """n x n periodic matrix with `values` on the (wrapped) `offsets`: (A v)_i = sum v_(i+o)."""
    i = np.arange(n)
    rows = np.concatenate([i] * len(offsets))
    cols = np.concatenate([(i + o) % n for o in offsets])
    vals = np.concatenate([np.full(n, v, float) for v in values])
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n, n))


def _pattern(nx: int, nz: int) -> sparse.csc_matrix:
    cx = _circulant(nx, (-1, 0, 1), (1.0, 1.0, 1.0))
    cz = sparse.diags([1.0, 1.0, 1.0], [-1, 0, 1], shape=(nz, nz))
    P = sparse.csc_matrix(sparse.kron(np.ones((3, 3)), sparse.kron(cx, cz)))
    P.data[:] = 1.0  # circulant wrap with nx = 2 could add entries
    P.sort_indices()
    return P


def _band(rows: int, cols: int, entries) -> sparse.csr_matrix:
    """rows x cols matrix with value v at (r, r + k) for (k, v) in `entries`."""
    r = np.arange(rows)
    return sparse.csr_matrix((np.concatenate([np.full(rows, v, float) for _, v in entries]),
                              (np.concatenate([r] * len(entries)), np.concatenate([r + k for k, _ in entries]))),
                             shape=(rows, cols))


class _Operators:
    """The scheme's linear face and cell operators on a patch of mx x mz cells with one ghost
    layer, vectors of a field's padded values ((mx + 2) (mz + 2), x-major), built once per
    patch shape: outputs on the patch's z-faces of its columns (mx (mz + 1)), on its x-faces
    (mx + 1 of them per row, between padded columns a and a + 1) and on its cells (mx mz)."""

    def __init__(self, mx, mz, hx, hz):
        self.mx, self.mz = mx, mz
        kron, csr = sparse.kron, sparse.csr_matrix
        px, pz = mx + 2, mz + 2
        Iz = sparse.identity(mz, format="csr")
        cols = _band(mx, px, [(1, 1.0)])                     # the patch's own columns
        cx = _band(mx, px, [(2, 0.5 / hx), (0, -0.5 / hx)])   # central x-difference at a column
        ax = _band(mx + 1, px, [(0, 0.5), (1, 0.5)])           # x-face average
        dx = _band(mx + 1, px, [(0, -1 / hx), (1, 1 / hx)])    # x-face compact difference
        back_x = _band(mx, px, [(0, -1 / hx), (1, 1 / hx)])
        fwd_x = _band(mx, px, [(1, -1 / hx), (2, 1 / hx)])
        div_x = _band(mx, mx + 1, [(0, -1 / hx), (1, 1 / hx)])  # x-faces a, a + 1 of cell a + 1
        avg_z = _band(mz + 1, pz, [(0, 0.5), (1, 0.5)])
        grad_z = _band(mz + 1, pz, [(0, -1 / hz), (1, 1 / hz)])
        R_z = _band(mz, pz, [(1, 1.0)])
        cz = _band(mz, pz, [(0, -0.5 / hz), (2, 0.5 / hz)])
        div_z = _band(mz, mz + 1, [(0, -1 / hz), (1, 1 / hz)])
        back_z = _band(mz, pz, [(0, -1 / hz), (1, 1 / hz)])
        fwd_z = _band(mz, pz, [(1, -1 / hz), (2, 1 / hz)])
        # z-faces: phi_f, d_x (tangential, averaged), d_z (compact); upwind phi below / above
        self.avg_zf, self.dx_zf, self.dz_zf = csr(kron(cols, avg_z)), csr(kron(cx, avg_z)), csr(kron(cols, grad_z))
        self.below_zf = csr(kron(cols, _band(mz + 1, pz, [(0, 1.0)])))
        self.above_zf = csr(kron(cols, _band(mz + 1, pz, [(1, 1.0)])))
        # x-faces: phi_f, d_x (compact), d_z (tangential, averaged); upwind phi left / right
        self.avg_xf, self.dx_xf, self.dz_xf = csr(kron(ax, R_z)), csr(kron(dx, R_z)), csr(kron(ax, cz))
        self.left_xf = csr(kron(_band(mx + 1, px, [(0, 1.0)]), R_z))
        self.right_xf = csr(kron(_band(mx + 1, px, [(1, 1.0)]), R_z))
        # divergences of face fluxes into cells
        self.div_z = csr(kron(sparse.identity(mx, format="csr"), div_z))
        self.div_x = csr(kron(div_x, Iz))
        # the cells' own values and the advection derivatives at the cells
        self.cells = csr(kron(cols, R_z))
        self.back_x, self.fwd_x, self.cen_x = csr(kron(back_x, R_z)), csr(kron(fwd_x, R_z)), csr(kron(cx, R_z))
        self.back_z, self.fwd_z, self.cen_z = csr(kron(cols, back_z)), csr(kron(cols, fwd_z)), csr(kron(cols, cz))

    def face_inputs(self, g):
        """(phi, u_x, u_z, w_x, w_z) on the z-faces and on the x-faces of padded data g (3, -1)."""
        phi, u, w = g
        z = (self.avg_zf @ phi, self.dx_zf @ u, self.dz_zf @ u, self.dx_zf @ w, self.dz_zf @ w)
        x = (self.avg_xf @ phi, self.dx_xf @ u, self.dz_xf @ u, self.dx_xf @ w, self.dz_xf @ w)
        return z, x


def _extension(nx, nz, coeffs) -> sparse.csr_matrix:
    """The linear part of the whole grid's patch (:func:`templates.plane2d.halo`) as a
    matrix: padded values (3 (nx + 2) (nz + 2)) = E @ data (3 nx nz) + constants; the x ghosts
    the periodic columns, the z ghosts alpha * (edge value) of the walls."""
    cols = np.concatenate(([nx - 1], np.arange(nx), [0]))
    X = sparse.csr_matrix((np.ones(nx + 2), (np.arange(nx + 2), cols)), shape=(nx + 2, nx))
    rows = np.concatenate(([0], np.arange(1, nz + 1), [nz + 1]))
    edge = np.concatenate(([0], np.arange(nz), [nz - 1]))
    blocks = []
    for k in range(3):
        vals = np.concatenate(([coeffs[k, 0, 0]], np.ones(nz), [coeffs[k, 1, 0]]))
        blocks.append(sparse.kron(X, sparse.csr_matrix((vals, (rows, edge)), shape=(nz + 2, nz))))
    return sparse.csr_matrix(sparse.block_diag(blocks))


def _wall_fold(mx, mz, coeffs, low, high) -> sparse.csr_matrix:
    """The padded values of a patch (3 (mx + 2) (mz + 2)) from those with the wall ghost rows
    left out: the identity, except that a wall's ghost row (z = 0 if `low`, z = H if `high`)
    is alpha * (edge value), so that a derivative by the ghost value moves to the edge value."""
    px, pz = mx + 2, mz + 2
    rows, cols, vals = [], [], []
    a, b = np.meshgrid(np.arange(px), np.arange(pz), indexing="ij")
    for k in range(3):
        col = (k * px + a) * pz + b
        val = np.ones(a.shape)
        if low:
            col[:, 0], val[:, 0] = col[:, 1], coeffs[k, 0, 0]
        if high:
            col[:, -1], val[:, -1] = col[:, -2], coeffs[k, 1, 0]
        rows.append(((k * px + a) * pz + b).ravel())
        cols.append(col.ravel())
        vals.append(val.ravel())
    n = 3 * px * pz
    return sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


class _PatchJacobian:
    """The Jacobian of the patch kernel's rates (3 mx mz, cell-major per field) by the padded
    values of its patch (3 (mx + 2) (mz + 2)): the chain rule through the face stencils with the
    generated kernels' exact partial derivatives (module doc). The same for the whole grid (its
    one patch, then :func:`_extension`) and for a block of a distributed grid."""

    def __init__(self, law, params, upwind, hx, hz):
        self.law, self.params, self.upwind, self.hx, self.hz = law, params, upwind, hx, hz
        self._ops = {}

    def ops(self, mx, mz) -> _Operators:
        if (mx, mz) not in self._ops:
            self._ops[(mx, mz)] = _Operators(mx, mz, self.hx, self.hz)
        return self._ops[(mx, mz)]

    def matrix(self, g) -> sparse.csr_matrix:
        """d rates / d padded values at the filled patch g (3, mx + 2, mz + 2)."""
        ops, law, params = self.ops(g.shape[1] - 2, g.shape[2] - 2), self.law, self.params
        g = g.reshape(3, -1)
        C = ops.cells
        phi, u, w = (C @ a for a in g)
        diag = sparse.diags
        qz, qx = ops.face_inputs(g)
        dz = law.stress_jacobian_array(*qz, params)  # d(p, txx, txz, tzz)/d(phi, ux, uz, wx, wz)
        dx = law.stress_jacobian_array(*qx, params)
        sz = law.stress_array(*qz, params)
        sx = law.stress_array(*qx, params)

        def d_flux(d, a, b=None):  # d(out a - out b)/d inputs
            return [d[5 * a + q] - (0 if b is None else d[5 * b + q]) for q in range(5)]

        def by_field(dflux, avg, ddx, ddz):  # sum over inputs of one field: (phi, u, w) blocks
            return (diag(dflux[0]) @ avg,
                    diag(dflux[1]) @ ddx + diag(dflux[2]) @ ddz,
                    diag(dflux[3]) @ ddx + diag(dflux[4]) @ ddz)

        # momentum: u rows use (tau_xx - p on x-faces, tau_xz on z-faces); w rows (tau_xz, tau_zz - p)
        fluxes = {"u": (sx[1] - sx[0], sz[2], d_flux(dx, 1, 0), d_flux(dz, 2)),
                  "w": (sx[2], sz[3] - sz[0], d_flux(dx, 2), d_flux(dz, 3, 0))}
        inv_phi = diag(1 / phi)
        rows = {}
        for comp, (fx, fz, dfx, dfz) in fluxes.items():
            bx = by_field(dfx, ops.avg_xf, ops.dx_xf, ops.dz_xf)
            bz = by_field(dfz, ops.avg_zf, ops.dx_zf, ops.dz_zf)
            blocks = [inv_phi @ (ops.div_x @ bx[m] + ops.div_z @ bz[m]) for m in range(3)]
            divf = ops.div_x @ fx + ops.div_z @ fz
            blocks[0] = blocks[0] - diag(divf / phi**2) @ C
            rows[comp] = blocks
        if self.upwind:
            Dx = diag((u > 0).astype(float)) @ ops.back_x + diag((u <= 0).astype(float)) @ ops.fwd_x
            Dz = diag((w > 0).astype(float)) @ ops.back_z + diag((w <= 0).astype(float)) @ ops.fwd_z
        else:
            Dx, Dz = ops.cen_x, ops.cen_z
        for comp, k in (("u", 1), ("w", 2)):
            dfx, dfz = Dx @ g[k], Dz @ g[k]
            blocks = rows[comp]
            blocks[k] = blocks[k] - diag(u) @ Dx - diag(w) @ Dz
            blocks[1] = blocks[1] - diag(dfx) @ C
            blocks[2] = blocks[2] - diag(dfz) @ C
        # mass: -div_z(phi_up w_f) - div_x(phi_up u_f)
        w_fz, u_fx = ops.avg_zf @ g[2], ops.avg_xf @ g[1]
        if self.upwind:
            up_z = diag((w_fz > 0).astype(float)) @ ops.below_zf + diag((w_fz <= 0).astype(float)) @ ops.above_zf
            up_x = diag((u_fx > 0).astype(float)) @ ops.left_xf + diag((u_fx <= 0).astype(float)) @ ops.right_xf
        else:
            up_z, up_x = ops.avg_zf, ops.avg_xf
        mass = [-(ops.div_z @ diag(w_fz) @ up_z + ops.div_x @ diag(u_fx) @ up_x),
                -ops.div_x @ diag(up_x @ g[0]) @ ops.avg_xf,
                -ops.div_z @ diag(up_z @ g[0]) @ ops.avg_zf]
        return sparse.bmat([mass, rows["u"], rows["w"]], format="csr")


class _Jacobian2D:
    """jac(t, y) -> CSC matrix of the 2-D right-hand side, by the chain rule (see module doc):
    the patch Jacobian on the whole grid's patch, times the patch's extension.

    ``pattern_values(t, y)`` returns the values in the CSC order of
    :meth:`ShearCell2DPDE.jacobian_sparsity` (what a sparse direct solver with a fixed
    pattern, e.g. CVODE's, fills).
    """

    def __init__(self, pde: ShearCell2DPDE, grid):
        self.pde = pde
        nx, nz, hx, hz = pde._spacing(grid)
        self.ghost = pde.ghost_coefficients(grid)
        self.patch = _PatchJacobian(pde._law(), pde.material.params, pde.advection == "upwind", hx, hz)
        self.extension = _extension(nx, nz, self.ghost)
        self.halo = pde._loops().halo
        self.shape = (3,) + tuple(grid.shape)
        self._grid = grid
        self._keys = None

    def _pattern_keys(self):
        if self._keys is None:
            P = _pattern(*self._grid.shape)
            cols = np.repeat(np.arange(P.shape[1]), np.diff(P.indptr))
            self._keys = cols.astype(np.int64) * P.shape[0] + P.indices
            self.pattern = P
        return self._keys

    def __call__(self, t, y):
        return self.matrix(y)

    def pattern_values(self, t, y) -> np.ndarray:
        """Jacobian values in the CSC order of the fixed pattern (zeros where J has none)."""
        keys = self._pattern_keys()
        J = self.matrix(y).tocoo()
        pos = np.searchsorted(keys, J.col.astype(np.int64) * J.shape[0] + J.row)
        out = np.zeros(keys.size)
        np.add.at(out, pos, J.data)
        return out

    def matrix(self, y) -> sparse.csc_matrix:
        g = self.halo(np.ascontiguousarray(np.asarray(y, float).reshape(self.shape)), self.ghost)
        return sparse.csc_matrix(self.patch.matrix(g) @ self.extension)
