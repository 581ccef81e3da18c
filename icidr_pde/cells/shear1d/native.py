"""The 1-D shear cell on the native engine: the compiled finite-volume problem.

:class:`FdProblem` binds the C of ``problem.c`` (finite volumes: the right-hand side and the
analytic band Jacobian printed from ``templates/fd.py``) for CVODE (:mod:`icidr_pde.native`).
The walls are the ghost-cell maps of :func:`icidr_pde.discretizations.core.ghost_coefficients`
(a test compares them with py-pde's boundary setters); the grid is py-pde's cell-centred
``CartesianGrid([[0, H]], N)``. The Chebyshev problem is :mod:`.native_cheb`.
"""

from __future__ import annotations

import numpy as np

from ...discretizations.core import ghost_coefficients
from ...discretizations.grid_size import FD
from ...native import NativeProblem, _pointer

__all__ = ["FdProblem", "fd_problem", "MAX_N"]

MAX_N = FD.max_N


class FdProblem(NativeProblem):
    """The compiled finite-volume problem of `rheology` on N cells of height H (interleaved
    vector y[3 i + k]): right-hand side, band Jacobian, M(phi), and CVODE; valid while
    lo < phi < hi, `bounds` (default: the law's range of phi).

    The band is ``jb[col, row - col + 5]`` (11 entries a column, :meth:`jacobian_band`);
    :meth:`jacobian_dense` spreads it into the (3N, 3N) matrix."""

    def __init__(self, rheology, N: int, H: float, *, advection: str = "upwind", V0: float = 1.0, bounds=None):
        from ...rheology import SHEAR_CELL

        params, lo, hi = self._open(rheology, bounds, SHEAR_CELL)
        self.N, self.H, self.h = int(N), float(H), float(H) / int(N)
        self.ghost = np.ascontiguousarray(ghost_coefficients(V0))
        self._attach(self.lib.icidr_fd_problem(self.N, self.h, int(advection == "upwind"), _pointer(self.ghost),
                                               _pointer(params), params.size, lo, hi))

    def jacobian_band(self, y) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=float)
        jb = np.empty((3 * self.N, 11))
        self.lib.icidr_fd_jacobian(self.handle, _pointer(y), _pointer(jb))
        return jb

    def jacobian_dense(self, y) -> np.ndarray:
        jb, n = self.jacobian_band(y), 3 * self.N
        J = np.zeros((n, n))
        for offset in range(-5, 6):
            cols = np.arange(max(0, -offset), min(n, n - offset))
            J[cols + offset, cols] = jb[cols, offset + 5]
        return J



def fd_problem(case, **options) -> FdProblem:
    """The compiled problem of the run path's finite-volume case `case` (its core's N, H, walls and advection)."""
    return FdProblem(case.rheology, case.N, case.H, advection=case.advection, V0=case.V0, **options)
