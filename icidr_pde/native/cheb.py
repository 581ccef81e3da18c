"""The native engine's Chebyshev collocation: problem and case without py-pde.

:class:`ChebProblem` is the compiled Chebyshev problem (the C printed from the numba
template ``discretizations/templates/cheb.py``: rates and dense Jacobian) with CVODE's dense linear
solver; :class:`ChebCase` is the case of :func:`icidr_pde.case.build_case` for
``discretization="cheb"`` (its core :class:`~icidr_pde.discretizations.cheb_core.Collocation`:
points, D, walls and initial state). The state is the py-pde path's vector (phi, u, w) in
blocks, so CVODE integrates the same numbers in the same order.
"""

from __future__ import annotations

import os

import numpy as np

from ..discretizations.grid_size import CHEB
from . import NativeCase, NativeProblem, _pointer

__all__ = ["ChebProblem", "ChebCase", "DENSE_SOLVERS", "DENSE_LU_DELTA_GAMMA", "MAX_N"]

MAX_N = CHEB.max_N  # and the memory a run needs: the py-pde path's limits (icidr_pde.discretizations.grid_size)
memory_estimate = CHEB.memory_estimate
DENSE_LU_DELTA_GAMMA = 1.0  # engines.sundae.DENSE_LU_DELTA_GAMMA (importing it would import scipy)
#: CVODE's dense linear solvers: LAPACK's LU (OpenBLAS, as the py-pde path's 'lapackdense'), SUNDIALS' own
DENSE_SOLVERS = ("lapack", "sundials")
#: OpenBLAS threads of a run where neither OPENBLAS_NUM_THREADS nor OMP_NUM_THREADS is set: one.
#: Measured on this 2-core machine at a load of 3, iCIDR sine N = 201, t = 15: 2.2 s with one
#: thread, 8.4 s with OpenBLAS's default two (a 603 x 603 LU gains little from a second core
#: and loses much when that core is busy). It is OpenBLAS's setting for the whole process.
BLAS_THREADS = 1
#: the one a run takes (the build falls back to SUNDIALS' own where scikit-sundae ships no LAPACK solver)
DENSE_SOLVER = "lapack"


class ChebProblem(NativeProblem):
    """The compiled Chebyshev problem of `rheology` with differentiation matrix `D` (N, N):
    right-hand side, dense analytic Jacobian, M(phi) and CVODE (dense LU: `solver`, one of
    :data:`DENSE_SOLVERS`; the factored Newton matrix kept until gamma changed by
    `delta_gamma`, default :data:`icidr_pde.engines.sundae.DENSE_LU_DELTA_GAMMA`)."""

    kernel_repeats = 20

    def __init__(self, rheology, D, *, bounds=None, solver: str = "lapack",
                 delta_gamma: float = DENSE_LU_DELTA_GAMMA):
        if solver not in DENSE_SOLVERS:
            raise ValueError(f"`solver` must be one of {DENSE_SOLVERS}; got {solver!r}")
        params, lo, hi = self._open(rheology, bounds)
        if not any(os.environ.get(name) for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")):
            self.lib.icidr_blas_threads(BLAS_THREADS)
        self.D = np.ascontiguousarray(D, dtype=float)
        self.N = int(self.D.shape[0])
        self.solver = solver
        self._attach(self.lib.icidr_cheb_problem(self.N, _pointer(self.D), _pointer(params), params.size, lo, hi,
                                                 int(solver == "lapack"), float(delta_gamma)))

    def jacobian_dense(self, y) -> np.ndarray:
        """The (3N, 3N) Jacobian d rates / d y."""
        y = np.ascontiguousarray(y, dtype=float)
        J = np.empty((3 * self.N, 3 * self.N), order="F")
        self.lib.icidr_cheb_jacobian(self.handle, _pointer(y), _pointer(J))
        return J


class ChebCase(NativeCase):
    """A Chebyshev case (``discretization="cheb"``) on the native engine: the state in blocks."""

    discretization = "cheb"

    def problem(self, **options) -> ChebProblem:
        return ChebProblem(self.rheology, self.scheme.D, **{"solver": DENSE_SOLVER, **options})
