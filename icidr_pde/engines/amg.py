"""Algebraic multigrid as CVODE's preconditioner of the Newton systems of the 2-D cell.

CVODE's BDF solves (I - gamma J) x = r at every Newton iteration. On the 2-D cell GMRES without a
preconditioner needs more iterations per solve the finer the grid (the momentum diffusion's
stiffness grows like 1/h^2: GMRES(20) to 1e-6 at gamma = 0.05 took 92 iterations at 64^2, 258 at
128^2). One V-cycle of algebraic multigrid built by pyamg (aggregation,
:func:`pyamg.smoothed_aggregation_solver`) on I - gamma J as GMRES's left preconditioner takes
19, 28, 42 iterations at 64^2, 128^2, 256^2 (docs/scaling.md).

* The aggregation is nodal: the fields (phi, u, w) of one cell are one 3 x 3 block of a BSR matrix,
  with the three constant fields as near-null space, so a cell's unknowns are aggregated together
  (the pressure couples phi and the velocity: pyamg's scalar smoothed aggregation of the same
  matrix took 15, 28, 54 iterations at 64^2, 128^2, 256^2, its nodal one 12, 17, 21).
* The tentative prolongators are not smoothed (``smooth=None``): each coarse operator is then the
  Galerkin product R (I - gamma J) P = I - gamma R J P (R P = I), linear in gamma. The hierarchy is
  built when CVODE asks for a new Jacobian; when only gamma changes, each level's operator is
  I - gamma C_l from the stored C_l = R J P, the same Galerkin operators a rebuild would give,
  for a sparse sum per level.
* The smoother is pyamg's Gauss-Seidel (forward before, backward after the coarse correction),
  the coarsest level is solved by LU.
* With the mass weights c (c J = 0: 1 on phi, 0 on the velocity) the V-cycle's
  output z is corrected by a multiple of a fixed vector q (c q = 1) so that c z = c r: then
  c P^-1 = c, the Krylov vectors keep c . v = 0, and the Newton corrections keep the mass to
  round-off as the unpreconditioned GMRES does.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu

__all__ = ["AmgHierarchy", "amg_preconditioner"]

#: the coarsest level's size in cells (pyamg's max_coarse): solved by a sparse LU
MAX_COARSE = 50


class AmgHierarchy:
    """Smoothed-aggregation hierarchy of M = I - gamma J on `fields` x cells unknowns.

    Args:
        J: the sparse Jacobian, unknowns field-major (all cells of field 0, then field 1, ...)
        fields: the number of fields per cell (the block size of the nodal aggregation)
        gamma: the step coefficient the aggregation is built for
    """

    def __init__(self, J, fields: int, gamma: float):
        import pyamg

        n = J.shape[0]
        cells = n // fields
        # node-major position k = fields * cell + field holds field-major unknown order[k]
        self.order = (np.arange(n) % fields) * cells + np.arange(n) // fields
        self.position = np.argsort(self.order)
        Jn = sparse.csr_matrix(J)[self.order][:, self.order].tocsr()
        M = sparse.bsr_matrix(sparse.identity(n, format="csr") - gamma * Jn, blocksize=(fields, fields))
        B = np.kron(np.ones((cells, 1)), np.eye(fields))
        ml = pyamg.smoothed_aggregation_solver(M, B=B, smooth=None, max_coarse=MAX_COARSE,
                                               improve_candidates=None, keep=False)
        self.P = [sparse.csr_matrix(level.P) for level in ml.levels[:-1]]
        self.R = [sparse.csr_matrix(level.R) for level in ml.levels[:-1]]
        self.C = [Jn]  # the Galerkin products R J P of each level
        for P, R in zip(self.P, self.R):
            self.C.append((R @ self.C[-1] @ P).tocsr())
        self.eye = [sparse.identity(C.shape[0], format="csr") for C in self.C]
        self.gamma = None
        self.at(gamma)

    @property
    def sizes(self) -> list[int]:
        """The number of unknowns on each level, finest first."""
        return [C.shape[0] for C in self.C]

    def at(self, gamma: float):
        """Set every level's operator to I - gamma C_l (and factor the coarsest)."""
        if gamma == self.gamma:
            return
        self.A = [(eye - gamma * C).tocsr() for eye, C in zip(self.eye, self.C)]
        self.coarse = splu(self.A[-1].tocsc())
        self.gamma = gamma

    def vcycle(self, r):
        """One V-cycle on M z = r (field-major vectors), zero initial guess."""
        return self._cycle(0, np.asarray(r, dtype=float)[self.order])[self.position]

    def _cycle(self, level, b):
        from pyamg.relaxation.relaxation import gauss_seidel

        if level == len(self.A) - 1:
            return self.coarse.solve(b)
        A = self.A[level]
        x = np.zeros_like(b)
        gauss_seidel(A, x, b, sweep="forward")
        x += self.P[level] @ self._cycle(level + 1, self.R[level] @ (b - A @ x))
        gauss_seidel(A, x, b, sweep="backward")
        return x


def amg_preconditioner(jac, fields: int, weights=None):
    """CVODE's left preconditioner: one V-cycle of :class:`AmgHierarchy` on I - gamma J.

    Args:
        jac: the analytic sparse Jacobian jac(t, y), unknowns field-major
        fields: fields per cell
        weights: the mass weights c (c J = 0) of the conserved quantity, or None

    J and the aggregation are rebuilt when CVODE asks for a new Jacobian (jok false), the level
    operators whenever gamma changes. With `weights` the output keeps c z = c r (module notes).
    """
    from sksundae.cvode import CVODEPrecond

    saved = {}
    if weights is not None:  # c z = c r by a multiple of q on the support of c (c q = 1)
        support = np.flatnonzero(weights)
        c = np.asarray(weights, dtype=float)[support]
        q = c / np.sum(c * c)

    def setup(t, y, yp, jok, jnew, gamma):
        if not jok or "hierarchy" not in saved:
            saved["hierarchy"] = AmgHierarchy(jac(t, np.array(y)), fields, gamma)
            jnew[0] = 1
        else:
            saved["hierarchy"].at(gamma)
            jnew[0] = 0

    def solve(t, y, yp, r, z, gamma, delta, lr):
        out = saved["hierarchy"].vcycle(r)
        if weights is not None:  # sums, not BLAS dot products: OpenBLAS's threads stall a loaded machine
            out[support] += np.sum(c * (r[support] - out[support])) * q
        z[:] = out

    return CVODEPrecond(setup, solve, side="left")
