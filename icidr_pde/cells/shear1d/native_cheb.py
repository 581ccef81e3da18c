"""The native engine's Chebyshev collocation: its compiled problem, without py-pde.

:class:`ChebProblem` is the compiled Chebyshev problem (the C printed from the numba
template ``discretizations/templates/cheb.py``: rates, dense Jacobian and the low-order band
preconditioner) with CVODE's Newton-Krylov solver (GMRES) or its dense LU, on the points, D and
walls of the core :class:`~icidr_pde.cells.shear1d.cheb_core.Collocation`
(:func:`cheb_problem`). The state is the py-pde path's vector (phi, u, w) in blocks, so CVODE integrates the same
numbers in the same order.
"""

from __future__ import annotations

import ctypes
import os

import numpy as np

from ...discretizations.grid_size import CHEB, check_memory
from ...cvode_settings import DENSE_LU_DELTA_GAMMA
from ...native import NativeProblem, NativeUnavailable, _pointer

__all__ = ["ChebProblem", "cheb_problem", "DENSE_SOLVERS", "DENSE_LU_DELTA_GAMMA", "LINEAR_SOLVERS", "KRYLOV", "MAX_N"]

MAX_N = CHEB.max_N  # and the memory a run needs: the py-pde path's limits (icidr_pde.discretizations.grid_size)
memory_estimate = CHEB.memory_estimate  # the dense LU's; a problem checks its own linear solver's (CHEB.estimate)
#: CVODE's dense linear solvers: LAPACK's LU (OpenBLAS, as the py-pde path's 'lapackdense'), SUNDIALS' own
DENSE_SOLVERS = ("lapack", "sundials")
#: OpenBLAS threads of a run where neither OPENBLAS_NUM_THREADS nor OMP_NUM_THREADS is set: one.
#: A 603 x 603 LU gains little from a second core and loses much when that core is busy (the
#: measurement: docs/chebyshev.md). It is OpenBLAS's setting for the whole process.
BLAS_THREADS = 1
#: the one a run takes (the build falls back to SUNDIALS' own where scikit-sundae ships no LAPACK solver)
DENSE_SOLVER = "lapack"
#: Newton's linear solves: "dense" (the dense LU of I - gamma J, :data:`DENSE_SOLVER`) or "krylov"
#: (GMRES, preconditioned as :data:`KRYLOV` says; cvode_driver.c, docs/chebyshev.md)
LINEAR_SOLVERS = ("dense", "krylov")
#: the one a run takes: GMRES with the band preconditioner, faster than the dense LU at equal
#: accuracy of t* (docs/chebyshev.md); the dense LU where the build has no SPGMR or LAPACK
LINEAR_SOLVER = "krylov"
PRECONDITIONERS = ("dense", "band")
#: the Krylov path's settings: the preconditioner ("dense": the LU of I - gamma J, J of an earlier
#: step; "band": the band LU of I - gamma J_lo, J_lo the same law's Jacobian with D replaced by
#: low-order differences on the same points), subspace dimension, GMRES tolerance factor
#: (CVODE's eplifac, its default 0.05), steps between preconditioner set-ups (msbp), steps after
#: which the preconditioner's Jacobian is stale (msbj), gamma change that refactors it (dgmax_lsetup)
KRYLOV = {"preconditioner": "band", "max_krylov": 5, "eps_lin": 0.05, "setup_steps": 20, "jac_steps": 51,
          "delta_gamma": 0.3}


class ChebProblem(NativeProblem):
    """The compiled Chebyshev problem of `rheology` with differentiation matrix `D` (N, N):
    right-hand side, dense analytic Jacobian, M(phi) and CVODE (dense LU: `solver`, one of
    :data:`DENSE_SOLVERS`; the factored Newton matrix kept until gamma changed by
    `delta_gamma`, default :data:`icidr_pde.cvode_settings.DENSE_LU_DELTA_GAMMA`); or, `linear_solver`
    "krylov" (default :data:`LINEAR_SOLVER`; the dense LU where the build cannot), GMRES with the
    low-order band preconditioner or a lagged dense LU, its settings `krylov` over :data:`KRYLOV`;
    given `weights`, the quadrature weights of phi, the Krylov path projects every step onto the
    initial mass, which the direct solves keep by themselves)."""

    kernel_repeats = 20

    def __init__(self, rheology, D, *, bounds=None, solver: str = "lapack",
                 delta_gamma: float | None = None, linear_solver: str | None = None, krylov: dict | None = None,
                 weights=None):
        if solver not in DENSE_SOLVERS:
            raise ValueError(f"`solver` must be one of {DENSE_SOLVERS}; got {solver!r}")
        default, linear_solver = linear_solver is None, LINEAR_SOLVER if linear_solver is None else linear_solver
        if linear_solver not in LINEAR_SOLVERS:
            raise ValueError(f"`linear_solver` must be one of {LINEAR_SOLVERS}; got {linear_solver!r}")
        settings = {**KRYLOV, **(krylov or {})}
        if set(settings) != set(KRYLOV):
            raise ValueError(f"`krylov` takes the keys {sorted(KRYLOV)}; got {sorted(krylov)}")
        if settings["preconditioner"] not in PRECONDITIONERS:
            raise ValueError(f"the preconditioner must be one of {PRECONDITIONERS}; got {settings['preconditioner']!r}")
        from ...rheology import SHEAR_CELL

        params, lo, hi = self._open(rheology, bounds, SHEAR_CELL)
        if linear_solver == "krylov" and not self.lib.icidr_has_krylov():
            if not default:
                raise NativeUnavailable("linear_solver 'krylov' needs SUNDIALS' SPGMR and LAPACK, "
                                        "not both shipped with this scikit-sundae")
            linear_solver = "dense"
        if delta_gamma is None:
            delta_gamma = settings["delta_gamma"] if linear_solver == "krylov" else DENSE_LU_DELTA_GAMMA
        N = int(np.shape(D)[0])
        band = linear_solver == "krylov" and settings["preconditioner"] == "band"
        need, note = CHEB.estimate(N, "krylov" if band else "dense")
        check_memory(f"`N` = {N} is too large for discretization 'cheb' with linear solver {linear_solver!r}"
                     f"{' (band preconditioner)' if band else ''}: it", need, note)
        if not any(os.environ.get(name) for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")):
            self.lib.icidr_blas_threads(BLAS_THREADS)
        self.D = np.ascontiguousarray(D, dtype=float)
        self.N = int(self.D.shape[0])
        self.solver = solver
        self._attach(self.lib.icidr_cheb_problem(self.N, _pointer(self.D), _pointer(params), params.size, lo, hi,
                                                 int(solver == "lapack"), float(delta_gamma)))
        self.linear_solver = linear_solver
        self.preconditioner = settings["preconditioner"]
        if linear_solver == "krylov":
            status = self.lib.icidr_cheb_krylov(self.handle, int(settings["max_krylov"]), float(settings["eps_lin"]),
                                                int(settings["setup_steps"]), int(settings["jac_steps"]),
                                                int(settings["preconditioner"] == "band"), _pointer(self.nodes()))
            if status < 0:
                raise MemoryError(f"Krylov preconditioner of N = {self.N} not allocated")
            if weights is not None and self.lib.icidr_cheb_conserve(
                    self.handle, _pointer(np.ascontiguousarray(weights, dtype=float))) < 0:
                raise MemoryError(f"mass weights of N = {self.N} not allocated")

    def nodes(self) -> np.ndarray:
        """The points of D: Trefethen's CGL points mapped to [0, H], H from D's corner entry
        D[0, 0] = -(2 (N - 1)^2 + 1) / (3 H)."""
        from ...discretizations.chebyshev import cgl_nodes

        return np.ascontiguousarray(cgl_nodes(self.N, -(2 * (self.N - 1) ** 2 + 1) / (3 * self.D[0, 0])))

    def jacobian_low_order(self, y) -> np.ndarray:
        """The band preconditioner's J_lo (3N, 3N) at y, in the interleaved ordering (phi_0, u_0, w_0, ...)."""
        y = np.ascontiguousarray(y, dtype=float)
        n = 3 * self.N
        jb = np.zeros((n, 11))  # column c holds rows c - 5 .. c + 5
        self.lib.icidr_cheb_low_order_jacobian(self.handle, _pointer(y), _pointer(self.nodes()), _pointer(jb))
        rows, cols = np.arange(n)[:, None] + np.arange(-5, 6), np.repeat(np.arange(n)[:, None], 11, axis=1)
        inside = (rows >= 0) & (rows < n)
        J = np.zeros((n, n))
        J[rows[inside], cols[inside]] = jb[inside]
        return J

    def counts(self) -> dict:
        """CVODE's counts (``lu``: factorisations, of the preconditioner on the Krylov path; ``jac``:
        analytic Jacobians) and, on the Krylov path, GMRES iterations and failures, preconditioner
        solves, products J v and their right-hand sides (``rhs`` includes them)."""
        counts = super().counts()
        if self.linear_solver == "krylov":
            out = (ctypes.c_long * 6)()
            self.lib.icidr_krylov_counts(self.handle, out)
            krylov = dict(zip(("krylov_iterations", "krylov_failures", "preconditioner_setups",
                               "preconditioner_solves", "jv", "jv_rhs"), map(int, out)))
            counts.update(krylov, rhs=counts["rhs"] + krylov["jv_rhs"])
        return counts

    def jacobian_dense(self, y) -> np.ndarray:
        """The (3N, 3N) Jacobian d rates / d y."""
        y = np.ascontiguousarray(y, dtype=float)
        J = np.empty((3 * self.N, 3 * self.N), order="F")
        self.lib.icidr_cheb_jacobian(self.handle, _pointer(y), _pointer(J))
        return J


def cheb_problem(case, **options) -> ChebProblem:
    """The compiled problem of the run path's Chebyshev case `case` (its core
    :class:`~icidr_pde.cells.shear1d.cheb_core.Collocation`: D and the quadrature weights)."""
    return ChebProblem(case.rheology, case.scheme.D, **{"solver": DENSE_SOLVER, "weights": case.scheme.weights, **options})
