"""Algebraic multigrid as CVODE's preconditioner of the Newton systems of the 2-D cell.

CVODE's BDF solves (I - gamma J) x = r at every Newton iteration. On the 2-D cell GMRES without a
preconditioner needs more iterations per solve the finer the grid (the momentum diffusion's
stiffness grows like 1/h^2: GMRES(20) to 1e-6 at gamma = 0.05 took 92 iterations at 64^2, 258 at
128^2). One V-cycle of algebraic multigrid (the aggregation by pyamg,
:func:`pyamg.smoothed_aggregation_solver`) on I - gamma J as GMRES's left preconditioner takes
18 and 31 iterations at 64^2 and 128^2 (and in CVODE's runs to t = 10 6.9, 10.3, 13.9 GMRES
iterations per Newton iteration at 64^2, 128^2, 256^2: docs/scaling.md).

* The aggregation is nodal: the fields (phi, u, w) of one cell are one 3 x 3 block of a BSR matrix,
  with the three constant fields as near-null space, so a cell's unknowns are aggregated together
  (the pressure couples phi and the velocity: pyamg's scalar smoothed aggregation of the same
  matrix took 15, 28, 54 iterations at 64^2, 128^2, 256^2, its nodal one 12, 17, 21).
* The tentative prolongators are not smoothed (``smooth=None``): each coarse operator is then the
  Galerkin product R (I - gamma J) P = I - gamma R J P (R P = I), linear in gamma. The hierarchy is
  built when CVODE asks for a new Jacobian; when only gamma changes, each level's operator is
  I - gamma C_l from the stored C_l = R J P, the same Galerkin operators a rebuild would give,
  for a sparse sum per level.
* The smoother is block Gauss-Seidel on each node's 3 x 3 block (forward before, backward after
  the coarse correction), the coarsest level is solved by its dense inverse; the whole V-cycle is
  one compiled call (:mod:`.amg_kernels`). pyamg builds the aggregation only.
* With the mass weights c (c J = 0: 1 on phi, 0 on the velocity) the V-cycle's
  output z is corrected by a multiple of a fixed vector q (c q = 1) so that c z = c r: then
  c P^-1 = c, the Krylov vectors keep c . v = 0, and the Newton corrections keep the mass to
  round-off as the unpreconditioned GMRES does.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from ...validation import ParameterError
from .amg_kernels import set_gamma, vcycle
from .precond import jacobian_precond

__all__ = ["AmgHierarchy", "amg_preconditioner"]

#: the coarsest level's size in unknowns (pyamg's max_coarse): solved by its dense inverse
MAX_COARSE = 50


class AmgHierarchy:
    """Aggregation hierarchy of M = I - gamma J on `fields` x cells unknowns, V-cycle compiled.

    Args:
        J: the sparse Jacobian, unknowns field-major (all cells of field 0, then field 1, ...)
        fields: the number of fields per cell (the block size of the nodal aggregation; 3)
        gamma: the step coefficient the aggregation is built for

    Each level's C_l = R_l ... R_0 J P_0 ... P_l is kept as 3 x 3 blocks (one block row a node,
    every diagonal block present) in the arrays of :mod:`.amg_kernels`, the operators
    I - gamma C_l beside them.
    """

    def __init__(self, J, fields: int, gamma: float):
        import pyamg

        if fields != 3:
            raise ParameterError(f"`fields` must be 3 (phi, u, w of a cell: the V-cycle's 3 x 3 blocks), got {fields!r}")
        n = J.shape[0]
        cells = n // fields
        # node-major position k = fields * cell + field holds field-major unknown order[k]
        self.order = (np.arange(n) % fields) * cells + np.arange(n) // fields
        self.position = np.argsort(self.order)
        J = sparse.coo_matrix(J)
        node = self.position  # the node-major index of each field-major unknown
        fine = _blocks(sparse.csr_matrix((J.data, (node[J.row], node[J.col])), shape=(n, n)))
        C = sparse.bsr_matrix(fine, blocksize=(3, 3))
        M = sparse.bsr_matrix((-gamma * fine.data, fine.indices, fine.indptr), shape=(n, n)) + \
            sparse.identity(n, format="bsr")
        B = np.kron(np.ones((cells, 1)), np.eye(fields))
        ml = pyamg.smoothed_aggregation_solver(sparse.bsr_matrix(M, blocksize=(3, 3)), B=B, smooth=None,
                                               max_coarse=MAX_COARSE, improve_candidates=None, keep=False)
        self.P = [sparse.csr_matrix(level.P) for level in ml.levels[:-1]]
        self.R = [sparse.csr_matrix(level.R) for level in ml.levels[:-1]]
        levels, C = [fine], C.tocsr()
        for P, R in zip(self.P, self.R):
            C = (R @ C @ P).tocsr()
            levels.append(_blocks(C))
        levels = [(level.indptr, level.indices, level.data) for level in levels]
        self.nodes = np.cumsum([0] + [level[0].size - 1 for level in levels]).astype(np.int64)
        rows = np.concatenate([np.repeat(np.arange(first, first + level[0].size - 1), np.diff(level[0]))
                               for level, first in zip(levels, self.nodes)])
        cols = np.concatenate([level[1] + first for level, first in zip(levels, self.nodes)])
        blocks = np.concatenate([level[2] for level in levels])
        split = {}
        for name, part in (("l", cols < rows), ("u", cols > rows)):
            split[name + "ptr"] = np.searchsorted(rows[part], np.arange(self.nodes[-1] + 1)).astype(np.int64)
            split[name + "col"] = np.ascontiguousarray(cols[part])
            split["C" + name.upper()] = np.ascontiguousarray(blocks[part])
        self.lptr, self.lcol, self.CL = split["lptr"], split["lcol"], split["CL"]
        self.uptr, self.ucol, self.CU = split["uptr"], split["ucol"], split["CU"]
        self.CD = np.ascontiguousarray(blocks[cols == rows])
        self.L, self.U, self.D = np.empty_like(self.CL), np.empty_like(self.CU), np.empty_like(self.CD)
        self.Dinv = np.empty_like(self.CD)
        self.agg = np.zeros(self.nodes[-1], dtype=np.int64)
        self.Pb = np.zeros((self.nodes[-1], 3, 3))
        for level, P in enumerate(self.P):  # tentative prolongators: one block a fine row
            Pb = sparse.bsr_matrix(P, blocksize=(3, 3))
            Pb.sort_indices()
            if not np.all(np.diff(Pb.indptr) == 1):
                raise RuntimeError("AmgHierarchy: a tentative prolongator has a row with other than one block")
            lo, hi = self.nodes[level], self.nodes[level + 1]
            self.agg[lo:hi] = Pb.indices + self.nodes[level + 1]
            self.Pb[lo:hi] = Pb.data
        self.x = np.zeros((self.nodes[-1], 3))
        self.b = np.zeros((self.nodes[-1], 3))
        self.gamma = None
        self.at(gamma)

    @property
    def sizes(self) -> list[int]:
        """The number of unknowns on each level, finest first."""
        return [3 * int(m) for m in np.diff(self.nodes)]

    def level(self, level: int, operator: str = "A") -> sparse.bsr_matrix:
        """Level `level`'s I - gamma C_l ('A') or C_l ('C') as a BSR matrix of node-major unknowns."""
        lo, hi = self.nodes[level], self.nodes[level + 1]
        parts = (self.L, self.D, self.U) if operator == "A" else (self.CL, self.CD, self.CU)
        rows, cols, blocks = [], [], []
        for ptr, col, part in ((self.lptr, self.lcol, parts[0]), (None, None, parts[1]),
                               (self.uptr, self.ucol, parts[2])):
            if ptr is None:
                rows.append(np.arange(lo, hi))
                cols.append(np.arange(lo, hi))
                blocks.append(part[lo:hi])
            else:
                rows.append(np.repeat(np.arange(lo, hi), np.diff(ptr[lo:hi + 1])))
                cols.append(col[ptr[lo]:ptr[hi]])
                blocks.append(part[ptr[lo]:ptr[hi]])
        rows, cols, blocks = (np.concatenate(a) for a in (rows, cols, blocks))
        first = np.lexsort((cols, rows))
        m = hi - lo
        return sparse.bsr_matrix((blocks[first], cols[first] - lo, np.searchsorted(rows[first] - lo, np.arange(m + 1))),
                                 shape=(3 * m, 3 * m))

    def at(self, gamma: float):
        """Set every level's operator to I - gamma C_l (and invert the coarsest)."""
        if gamma == self.gamma:
            return
        set_gamma(gamma, self.CL, self.CD, self.CU, self.L, self.D, self.U, self.Dinv)
        self.coarse_inv = np.linalg.inv(self.level(len(self.nodes) - 2).toarray())
        self.gamma = gamma

    def vcycle(self, r, out=None):
        """One V-cycle on M z = r (field-major vectors), zero initial guess; z into `out` if given."""
        z = np.empty(self.nodes[1] * 3) if out is None else out
        vcycle(np.asarray(r, dtype=float), z, self.nodes, self.lptr, self.lcol, self.L, self.uptr, self.ucol, self.U,
               self.Dinv, self.agg, self.Pb, self.coarse_inv, self.x, self.b)
        return z

    solve = vcycle  # the preconditioner's application (:func:`.precond.jacobian_precond`)


def _blocks(A) -> sparse.bsr_matrix:
    """A (node-major unknowns) as sorted 3 x 3 blocks, every diagonal block stored (zero where A
    has none: the sweeps divide by it)."""
    B = sparse.bsr_matrix(A, blocksize=(3, 3))  # A canonical: no duplicate blocks
    B.sort_indices()
    m = B.shape[0] // 3
    rows = np.repeat(np.arange(m), np.diff(B.indptr))
    missing = np.setdiff1d(np.arange(m), rows[B.indices == rows])
    if missing.size:
        rows, cols = np.concatenate([rows, missing]), np.concatenate([B.indices, missing])
        first = np.lexsort((cols, rows))
        data = np.concatenate([B.data, np.zeros((missing.size, 3, 3))])[first]
        B = sparse.bsr_matrix((data, cols[first], np.searchsorted(rows[first], np.arange(m + 1))), shape=B.shape)
    return B


def amg_preconditioner(jac, fields: int, weights=None):
    """CVODE's left preconditioner: one V-cycle of :class:`AmgHierarchy` on I - gamma J.

    Args:
        jac: the analytic sparse Jacobian jac(t, y), unknowns field-major
        fields: fields per cell
        weights: the mass weights c (c J = 0) of the conserved quantity, or None

    J and the aggregation are rebuilt when CVODE asks for a new Jacobian (jok false), the level
    operators whenever gamma changes. With `weights` the output keeps c z = c r (module notes).
    """
    return jacobian_precond(jac, lambda J, gamma: AmgHierarchy(J, fields, gamma), weights)
