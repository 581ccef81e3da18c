"""The 2-D cell's finite volumes on patches: a block of cells with one ghost layer.

:class:`Patches` is the scheme's right-hand side and Jacobian on the blocks of a distributed
grid (PETSc's DMDA); the whole grid is the one patch whose x ghosts are the periodic columns and
whose z ghosts the walls' rows (:meth:`.pde.ShearCell2DPDE.patches`). The Jacobian is analytic:
the chain rule through the face stencils (:class:`_Operators`, sparse linear operators built
once per patch shape) with the generated kernels' exact partial derivatives
(:class:`_PatchJacobian`); the whole grid's (:class:`_Jacobian2D`) is the patch Jacobian times
the patch's extension, on the fixed pattern of every cell coupled to its 3 x 3 neighbourhood.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np
from scipy import sparse

if TYPE_CHECKING:
    from .pde import ShearCell2DPDE

__all__ = ["Patches"]


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
