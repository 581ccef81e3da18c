"""PETSc through petsc4py behind the :class:`~.base.Engine` protocol: TS (BDF by default), SNES
Newton on the analytic sparse Jacobian, KSP GMRES preconditioned by block Jacobi/ILU (or GAMG, ASM: options),
on one rank or many (``mpiexec -n P``).

Distribution, first step: the state vector, the Jacobian matrix and every Krylov and multigrid
operation are distributed over the ranks (PETSc's row blocks), while the scheme's kernels, which
work on the whole periodic grid (:mod:`icidr_pde.templates.cartesian2d`), are evaluated
*replicated*: the state is gathered to every rank for each right-hand side and Jacobian, every
rank evaluates the whole grid and keeps its own rows. The linear algebra scales; the kernels do
not. A halo kernel would need the scheme to evaluate a row block of cells from the block and
one layer of neighbouring cells in x (periodic) and z (walls), i.e. a DMDA with stencil width 1
and the kernels written on a local patch with ghost cells.

Options pass through: ``options={"ksp_type": "bcgs", ...}`` or the environment variable
``PETSC_OPTIONS="-ts_type rosw -pc_type asm"``; PETSc's ``-ts_*``, ``-snes_*``, ``-ksp_*`` and
``-pc_*`` options are read after the defaults below are set, so they override them.
"""

from __future__ import annotations

import numpy as np

from .base import Engine, Problem
from .time_scale import MIN_STEP_FRACTION

__all__ = ["PetscEngine", "DEFAULTS", "PETSC_MISSING", "linear_solver_name", "rank"]

#: the engine's defaults: PETSc's BDF (order 2, adaptive step), Newton, GMRES preconditioned by
#: block Jacobi with ILU(0) blocks (one block per rank; on one rank ILU(0)). Measured on iCIDR
#: bump2d 64^2 to t = 2 (docs/distributed.md): KSPSolve 5.1 s with bjacobi/ILU, 5.1 s ASM,
#: 16.2 s GAMG (its setup at each Newton matrix and its Chebyshev smoothing cost more than the
#: ILU's extra iterations at this size); -pc_type gamg selects it
DEFAULTS = {"ts_type": "bdf", "snes_type": "newtonls", "snes_linesearch_type": "basic", "ksp_type": "gmres",
            "pc_type": "bjacobi", "sub_pc_type": "ilu", "ksp_rtol": 1e-8}
#: the scheme's Jacobian of f is re-evaluated after this many steps, or after a rejected step or a
#: failed Newton solve (as CVODE does); in between TS forms shift I - J from the kept values
JAC_MAX_AGE = 20

PETSC_MISSING = ("the PETSc engine needs petsc4py: pip install -e \".[petsc]\" "
                 "(PETSc builds from source once, docs/distributed.md)")


def _petsc():
    try:
        from petsc4py import PETSc
    except ImportError as err:
        raise ImportError(PETSC_MISSING) from err
    return PETSc


def rank() -> int:
    """This process's rank in PETSc's COMM_WORLD (0 alone prints and writes); ImportError naming
    the extra where petsc4py is missing."""
    return _petsc().COMM_WORLD.rank


def linear_solver_name(options=None) -> str:
    """The TS, SNES, KSP and PC types of a run with these option overrides (and PETSC_OPTIONS)."""
    PETSc = _petsc()
    db = PETSc.Options()
    merged = dict(DEFAULTS, **(options or {}))
    names = [db.getString(key, str(merged[key])) for key in ("ts_type", "snes_type", "ksp_type", "pc_type")]
    return "PETSc TS {} + SNES {} + KSP {} + PC {}".format(*names)


class PetscEngine(Engine):
    """PETSc's TS on a :class:`Problem` with a 'sparse' Jacobian (the 2-D cell, fv2d).

    The AIJ matrix is preallocated once from the Jacobian's pattern (COO), and each Jacobian
    evaluation sets only its values. Each accepted step is checked by ``problem.check``; a step
    that PETSc cannot take (nonlinear solve diverged, step below the minimum) ends the run as a
    value (t_good, y_good, reason), as on the other engines. Dense output by ``TSInterpolate``.
    """

    name = "petsc"
    methods = ("PETSC-BDF",)

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver="", options=None):
        PETSc = _petsc()
        if problem.jacobian.mode != "sparse":
            raise ValueError(f"the PETSc engine takes a 'sparse' Jacobian; got {problem.jacobian.mode!r}")
        self.PETSc, self.problem, self.comm = PETSc, problem, PETSc.COMM_WORLD
        PETSc.Sys.pushErrorHandler("python")  # an interrupt is said once, by the run path, not as PETSc's traceback
        self.n_jac, self._values, self._evaluated, self._last_keys = 0, None, (0, 0, 0), None
        n = problem.y0.size
        self._pattern(problem.jacobian.sparsity, n)
        self.x = self.J.createVecLeft()
        self.rows = slice(*self.x.getOwnershipRange())
        self.x.setArray(problem.y0[self.rows])
        self._gather, self._full = PETSc.Scatter.toAll(self.x)
        self.ts = self._make_ts(t0, rtol, atol, max_step, first_step, options)
        self.linear_solver = "PETSc TS {} + SNES {} + KSP {} + PC {}".format(
            self.ts.getType(), self.ts.getSNES().getType(), self.ts.getSNES().getKSP().getType(),
            self.ts.getSNES().getKSP().getPC().getType())
        if self.comm.size > 1:
            self.linear_solver += f" ({self.comm.size} MPI ranks)"
        self.t, self.y = float(t0), np.array(problem.y0, dtype=float)
        self._work = self.x.duplicate()

    def _pattern(self, sparsity, n):
        """The AIJ matrix with the Jacobian's pattern, this rank's rows preallocated by COO."""
        from scipy import sparse

        P = sparse.csr_matrix(sparsity)
        P.sort_indices()
        self.J = self.PETSc.Mat().create(comm=self.PETSc.COMM_WORLD)
        self.J.setSizes([n, n])
        self.J.setType(self.PETSc.Mat.Type.AIJ)
        self.J.setUp()
        start, end = self.J.getOwnershipRange()
        local = P[start:end]
        rows = (np.repeat(np.arange(end - start), np.diff(local.indptr)) + start).astype(self.PETSc.IntType)
        cols = local.indices.astype(self.PETSc.IntType)
        # this rank's pattern entries as row * n + col, sorted (before PETSc, which may overwrite
        # the index arrays it is given: MatSetPreallocationCOO on MPIAIJ does)
        self._keys = rows.astype(np.int64) * n + cols
        self.J.setPreallocationCOO(rows.copy(), cols.copy())
        self._n = n

    def _gathered(self, vec) -> np.ndarray:
        """The whole vector on every rank (the replicated kernels' input)."""
        self._gather.scatter(vec, self._full, addv=self.PETSc.InsertMode.INSERT,
                             mode=self.PETSc.ScatterMode.FORWARD)
        return np.array(self._full.getArray(readonly=True))

    def _make_ts(self, t0, rtol, atol, max_step, first_step, options):
        PETSc, problem = self.PETSc, self.problem
        db = PETSc.Options()
        for key, value in dict(DEFAULTS, **(options or {})).items():
            if not db.hasName(key) or key in (options or {}):
                db.setValue(key, value)
        ts = PETSc.TS().create(comm=self.comm)
        ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
        F = self.x.duplicate()
        fun = problem.fun
        rows = self.rows

        def rhs(ts, t, x, f):
            f.setArray(fun(t, self._gathered(x))[rows])

        def jacobian(ts, t, x, J, P):
            if self._stale(ts):
                self.n_jac += 1
                self._values = self._pattern_values(problem.jacobian.jac(t, self._gathered(x)))
            J.setValuesCOO(self._values, addv=PETSc.InsertMode.INSERT_VALUES)

        ts.setRHSFunction(rhs, F)
        ts.setRHSJacobian(jacobian, self.J, self.J)
        ts.setTime(t0)
        self.time_scale = problem.time_scale(t0)
        ts.setTimeStep(first_step if first_step is not None else self.time_scale)
        ts.setMaxTime(1e300)
        ts.setMaxSteps(10**9)
        ts.setExactFinalTime(PETSc.TS.ExactFinalTime.INTERPOLATE)
        ts.setTolerances(rtol=rtol, atol=atol)
        ts.setMaxSNESFailures(-1)  # a failed Newton solve halves the step; the minimum step ends it
        ts.setErrorIfStepFails(False)
        ts.setSolution(self.x)
        if not db.hasName("ts_adapt_dt_min"):  # relative to the fastest time scale, as on CVODE
            db.setValue("ts_adapt_dt_min", MIN_STEP_FRACTION * self.time_scale)
        if np.isfinite(max_step) and not db.hasName("ts_adapt_dt_max"):
            db.setValue("ts_adapt_dt_max", max_step)
        ts.setFromOptions()
        ts.setUp()
        return ts

    def _stale(self, ts) -> bool:
        """Whether the kept Jacobian values are too old: JAC_MAX_AGE steps, or a step rejected or
        a Newton solve failed since they were evaluated."""
        now = (ts.getStepNumber(), ts.getStepRejections(), ts.getSNESFailures())
        if self._values is None or now[0] - self._evaluated[0] >= JAC_MAX_AGE or now[1:] != self._evaluated[1:]:
            self._evaluated = now
            return True
        return False

    def _pattern_values(self, J) -> np.ndarray:
        """The values of the sparse J (scipy) in this rank's pattern order (COO)."""
        from scipy import sparse

        J = sparse.coo_matrix(J)
        keys = J.row.astype(np.int64) * self._n + J.col
        if self._last_keys is None or not np.array_equal(keys, self._last_keys):
            pos = np.searchsorted(self._keys, keys)
            mine = (pos < self._keys.size) & (self._keys[np.minimum(pos, self._keys.size - 1)] == keys)
            self._last_keys, self._map = keys, (pos[mine], mine)
        pos, mine = self._map
        values = np.zeros(self._keys.size)
        np.add.at(values, pos, J.data[mine])
        return values

    def advance(self, t_end):
        PETSc, ts, check = self.PETSc, self.ts, self.problem.check
        while self.t < t_end:
            try:
                ts.step()
            except PETSc.Error as err:  # an interrupt inside a callback reaches here as PETSc's error
                if isinstance(err.__cause__, KeyboardInterrupt):
                    raise err.__cause__ from None
                raise
            reason = ts.getConvergedReason()
            if reason < 0:
                return self.t, self.y, f"integrator failed (PETSc TS: {_reason_name(PETSc, reason)}, " \
                                       f"dt = {ts.getTimeStep():.3g})"
            y = self._gathered(self.x)
            why = check(y)
            if why:
                return float(ts.getTime()), y, why
            self.t, self.y = float(ts.getTime()), y
        return None

    def value_at(self, t):
        if t >= self.t:
            return self.y
        self.ts.interpolate(t, self._work)
        return self._gathered(self._work)

    def counts(self):
        return int(self.ts.getStepNumber()), self.n_jac, None


def _reason_name(PETSc, reason) -> str:
    names = {v: k for k, v in vars(PETSc.TS.ConvergedReason).items() if isinstance(v, int)}
    return names.get(reason, str(reason))
