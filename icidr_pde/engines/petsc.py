"""PETSc through petsc4py behind the :class:`~.base.Engine` protocol: TS (BDF by default), SNES
Newton on the analytic sparse Jacobian, KSP GMRES preconditioned by the linear solver's shell
preconditioner where it brings one (the 2-D cell's x-Fourier inverse,
:class:`~.linear.xfourier.PetscXFourier`, on a grid split along z only), else by block
Jacobi/ILU (or GAMG, ASM: options, ``-pc_type`` overriding either), on one rank or many
(``mpiexec -n P``).

Distribution: where the problem brings its scheme on patches (``Problem.patches``, the 2-D
cell's :class:`~icidr_pde.cells.plane2d.pde.Patches`), the grid is a DMDA (x
periodic, z ghosted beyond the walls, the three fields interleaved, a box stencil of width 1)
and each rank owns a block of cells: for each right-hand side it receives one ghost layer from
its neighbours (``globalToLocal``) and evaluates the patch kernel on its own cells; each
Jacobian is its own cells' rows, assembled from its patch alone (:class:`BlockGrid`). The
state vector, the matrix, GMRES and the preconditioner are distributed by the same blocks.
Each accepted step is checked (finite, phi in range) by each rank on its own block and one
reduction over the ranks, which also carries an interrupt (SIGINT, SIGTERM) to every rank after
the same step; max|w| at an output is a reduction too; the state is gathered only where the
run keeps it (snapshots, the last output) or where it is invalid. The run path's problem of
blocks (:func:`block_problem`) is each rank's own: its initial data, its rows of the Jacobian's
pattern and values, and nothing of the whole grid, whose states are gathered on rank 0 alone
(what its outputs keep; docs/distributed.md measures the memory per rank). A problem without patches
(any other sparse problem) is evaluated replicated: the state gathered to every rank for each
right-hand side and Jacobian, each rank keeping its own rows. What the ranks gain
(benchmarks/petsc_ranks.py) is in docs/distributed.md.

Options pass through: ``options={"ksp_type": "bcgs", ...}`` or the environment variable
``PETSC_OPTIONS="-ts_type rosw -pc_type asm"``; PETSc's ``-ts_*``, ``-snes_*``, ``-ksp_*`` and
``-pc_*`` options are read after the defaults below are set, so they override them.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import sys

import numpy as np
from numba import njit

from .. import loaded_mpi, mpi_ranks
from ..kernel_cache import numba_saves_may_fail
from ..validation import ParameterError
from .base import Engine, Problem
from ..cvode_settings import A_STABLE_ORDER
from ..time_scale import MIN_STEP_FRACTION, fastest_time_scale

numba_saves_may_fail()

__all__ = ["PetscEngine", "BlockGrid", "block_problem", "DEFAULTS", "PETSC_MISSING", "linear_solver_name", "rank", "mpiexec"]

#: the engine's defaults: PETSc's BDF (order 2, adaptive step), Newton, GMRES preconditioned by
#: block Jacobi with ILU(0) blocks (one block per rank; on one rank ILU(0)): on iCIDR bump2d
#: 64^2 as fast as ASM and faster than GAMG, whose setup at each Newton matrix and Chebyshev
#: smoothing cost more than the ILU's extra iterations at this size (the times:
#: docs/distributed.md, the table of -pc_type); -pc_type gamg selects it
DEFAULTS = {"ts_type": "bdf", "snes_type": "newtonls", "snes_linesearch_type": "basic", "ksp_type": "gmres",
            "pc_type": "bjacobi", "sub_pc_type": "ilu", "ksp_rtol": 1e-8, "snes_mf_operator": True}
#: snes_mf_operator: GMRES solves with the Jacobian of the current state (its product by difference
#: quotients), the kept assembled Jacobian (JAC_MAX_AGE) only preconditions, as CVODE's GMRES does.
#: With the kept Jacobian as the operator, the waves below Newton's tolerance followed its stale
#: linearization instead of BDF2, and the grid-scale x-waves grew (docs/distributed.md)
#: PETSc's error code of an argument out of range (a grid too small for the DMDA's split)
PETSC_ERR_ARG_OUTOFRANGE = 63
#: the preconditioners whose blocks the ``sub_*`` defaults set up
BLOCK_PCS = ("bjacobi", "asm")
#: the scheme's Jacobian of f is re-evaluated after this many steps, or after a rejected step or a
#: failed Newton solve (as CVODE does); in between TS forms shift I - J from the kept values
JAC_MAX_AGE = 20

PETSC_MISSING = ("the PETSc engine needs petsc4py: pip install -e \".[petsc]\" "
                 "(PETSc builds from source once, docs/distributed.md)")


def other_mpi() -> str | None:
    """What has loaded another MPI library into this process (:mod:`icidr_pde.loaded_mpi`), as the
    refusal names it, or None: PETSc built on another MPI aborts in MPI_Init beside it, so it is
    refused before it starts."""
    found = loaded_mpi.loaded()
    return ", ".join(f"{who} ({mpi})" for who, mpi in found.items()) or None


def _petsc():
    other = other_mpi()
    if ("petsc4py.PETSc" not in sys.modules and sys.modules.get("petsc4py", "") is not None
            and importlib.util.find_spec("petsc4py") is not None and other):
        raise ImportError(f"the PETSc engine cannot start in a process that has run {other}, and PETSc's "
                          "MPI is another: run it in a process of its own")
    try:
        PETSc = mpi_ranks.start_petsc()
    except ImportError as err:
        raise ImportError(PETSC_MISSING) from err
    launched = mpi_ranks.launched()
    if PETSc.COMM_WORLD.size == 1 and launched > 1:
        raise ImportError(f"this process is one of {launched} started by the mpiexec of another MPI than PETSc's "
                          "(or by srun without the --mpi plugin of PETSc's MPI), so each would run the whole grid "
                          f"alone: start them with {mpiexec()}")
    mpi_ranks.abort_on_uncaught()  # an exception on one rank ends them all, not only that one
    return PETSc


def mpiexec() -> str | None:
    """The launcher of the MPI PETSc was built on (its configuration's MPIEXEC), or None where
    petsc4py or that file is missing. Not `mpiexec` on PATH: another MPI's may come first (the
    [dem] extra's MPICH in the environment's bin/), and PETSc's ranks would not see each other."""
    try:
        import petsc4py
    except ImportError:
        return None
    config = petsc4py.get_config()
    variables = os.path.join(config["PETSC_DIR"], config.get("PETSC_ARCH") or "", "lib", "petsc", "conf",
                             "petscvariables")
    try:
        with open(variables) as fh:
            found = [line.split("=", 1)[1].strip() for line in fh if line.split("=", 1)[0].strip() == "MPIEXEC"]
    except OSError:
        return None
    return found[0] if found and os.path.isfile(found[0]) else None


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
    """PETSc's TS on a :class:`Problem` with a 'sparse' Jacobian (the 2-D cell, plane2d).

    The AIJ matrix is preallocated once from the Jacobian's pattern (COO), and each Jacobian
    evaluation sets only its values. Each accepted step is checked by ``problem.check``; a step
    that PETSc cannot take (nonlinear solve diverged, step below the minimum) ends the run as a
    value (t_good, y_good, reason), as on the other engines. Dense output by ``TSInterpolate``.
    Each Newton correction keeps the initial mass of phi (:meth:`_keep_mass`).
    """

    name = "petsc"
    methods = ("PETSC-BDF",)

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver="", options=None, max_order=A_STABLE_ORDER):
        PETSc = _petsc()
        if problem.jacobian.mode != "sparse":
            raise ValueError(f"the PETSc engine takes a 'sparse' Jacobian; got {problem.jacobian.mode!r}")
        self.PETSc, self.problem, self.comm = PETSc, problem, PETSc.COMM_WORLD
        PETSc.Sys.pushErrorHandler("python")  # an interrupt is said once, by the run path, not as PETSc's traceback
        self.n_jac, self._values, self._evaluated, self._last_keys = 0, None, (0, 0, 0), None
        # a shell preconditioner of the linear solver's (the x-Fourier inverse) asks for its split of the grid
        shell = getattr(linear_solver, "shell", None) if problem.patches is not None else None
        # a problem whose patches are a BlockGrid is this rank's block (its y0 the block's values, its
        # grid split as block_problem was told): nothing of the whole grid is built here, and whole
        # states are gathered on rank 0 alone
        self.blocks = isinstance(problem.patches, BlockGrid)
        if self.blocks:
            self.grid = problem.patches
        else:
            split = linear_solver.proc_sizes(self.comm.size) if shell is not None else None
            self.grid = None if problem.patches is None else BlockGrid(PETSc, problem.patches, self.comm, split)
        self._shell = None if shell is None else shell(PETSc, self.grid)
        self._solver_options = getattr(linear_solver, "petsc_options", {})
        if self.grid is None:
            n = problem.y0.size
            self.x = PETSc.Vec().createMPI(n, comm=self.comm)
            self.order = np.arange(n)
            self.x.setArray(problem.y0[slice(*self.x.getOwnershipRange())])
            self._gather, self._full = PETSc.Scatter.toAll(self.x)
        else:
            self.x = self.grid.da.createGlobalVec()
            n = self.x.getSize()
            if self.blocks:
                self.x.setArray(problem.y0)
            else:
                self.grid.scatter_in(problem.y0, self.x)
            if not self.grid.has_jacobian:  # the problem's whole Jacobian, its rows picked by the whole map
                self.order = self.grid.order
        self._pattern(problem.jacobian.sparsity, n)
        self._flags = PETSc.Vec().createMPI((1, None), comm=self.comm)  # one number per rank, reduced by max
        self.max_order = int(max_order)  # TSBDF's order
        self.ts = self._make_ts(t0, rtol, atol, max_step, first_step, options)
        pc = self.ts.getSNES().getKSP().getPC()
        self.linear_solver = "PETSc TS {} + SNES {} + KSP {} + PC {}".format(
            self.ts.getType(), self.ts.getSNES().getType(), self.ts.getSNES().getKSP().getType(),
            "x-Fourier" if self._shell is not None and pc.getType() == "python" else pc.getType())
        self.ranks = self.comm.size
        self.ran = "PETSC-" + str(self.ts.getType()).upper()  # -ts_type may have changed the default BDF
        if self.ranks > 1:
            self.linear_solver += f" ({self.ranks} MPI ranks)"
        self.t = float(t0)
        self._work, self._good, self._kept = self.x.duplicate(), self.x.copy(), self.x.copy()
        # the last output (time, whole state once gathered); _good: the last accepted state
        self._kept_t = float(t0)
        self._kept_y = None if self.blocks else np.array(problem.y0, dtype=float)
        self._inside = None if self.grid is None else self.grid.patches.inside

    def _pattern(self, sparsity, n):
        """The AIJ matrix with the Jacobian's pattern, its rows distributed as the state vector's,
        this rank's rows preallocated by COO: on a grid of blocks the stencil's slots of its own
        cells' rows (:meth:`BlockGrid.stencil_pattern`: each Jacobian's values are placed by
        arithmetic, :meth:`BlockGrid.jacobian_slots`), else this rank's rows of the problem's
        `sparsity` (in the engine's ordering: `self.order` maps the problem's unknowns to
        PETSc's), each Jacobian's entries found in it by :meth:`_pattern_values`."""
        from scipy import sparse

        start, end = self.x.getOwnershipRange()
        self.J = self.PETSc.Mat().create(comm=self.comm)
        self.J.setSizes([(end - start, n), (end - start, n)])
        self.J.setType(self.PETSc.Mat.Type.AIJ)
        self.J.setUp()
        self._n = n
        if self.grid is not None and self.grid.has_jacobian:
            rows, cols = self.grid.stencil_pattern()
            self.J.setPreallocationCOO(rows.astype(self.PETSc.IntType), cols.astype(self.PETSc.IntType))
            self._keys = None  # the values are placed by the stencil's slots, not found in sorted keys
            return
        P = sparse.coo_matrix(sparsity)
        rows, cols = self.order[P.row], self.order[P.col]
        mine = (rows >= start) & (rows < end)
        # this rank's pattern entries as row * n + col, sorted (before PETSc, which may overwrite
        # the index arrays it is given: MatSetPreallocationCOO on MPIAIJ does)
        self._keys = _sorted_unique(rows[mine].astype(np.int64) * n + cols[mine])
        self.J.setPreallocationCOO((self._keys // n).astype(self.PETSc.IntType),
                                   (self._keys % n).astype(self.PETSc.IntType))

    def _gathered(self, vec) -> np.ndarray:
        """The whole vector in the problem's ordering (the states kept at outputs, an invalid
        state's check, and the input of the replicated right-hand side and Jacobian): on rank 0
        alone (an empty array elsewhere) where the problem is a grid of blocks, else on every rank."""
        if self.blocks:
            return self.grid.to_root(vec)
        if self.grid is not None:
            return self.grid.gathered(vec)
        self._gather.scatter(vec, self._full, addv=self.PETSc.InsertMode.INSERT,
                             mode=self.PETSc.ScatterMode.FORWARD)
        return np.array(self._full.getArray(readonly=True))

    def _make_ts(self, t0, rtol, atol, max_step, first_step, options):
        from scipy import sparse

        PETSc, problem = self.PETSc, self.problem
        db = PETSc.Options()
        options = options or {}
        defaults = dict(DEFAULTS, **(self._solver_options if self._shell is not None else {}))
        # the defaults are this run's, not the next run's (the options database outlives a run, and the
        # next may take another linear solver's): those the user did not set are taken out again once
        # read, but for the blocks' (sub_*: read when the blocks are set up, at the first solve)
        own = [key for key in defaults if key not in options and not db.hasName(key) and not key.startswith("sub_")]
        pc_type = options.get("pc_type") or db.getString("pc_type", defaults["pc_type"])
        if (options.get("ts_type") or db.getString("ts_type", DEFAULTS["ts_type"])) == "bdf":
            # the run's setting, set on every run (the options database outlives a run)
            options = dict(options, ts_bdf_order=self.max_order)
        for key, value in dict(defaults, **options).items():
            if key.startswith("sub_") and key not in options and pc_type not in BLOCK_PCS:
                continue  # another -pc_type has no blocks: PETSc would warn of an unused option
            if not db.hasName(key) or key in options:
                db.setValue(key, value)
        ts = PETSc.TS().create(comm=self.comm)
        ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
        F = self.x.duplicate()
        fun = problem.fun
        # the shell preconditioner needs no assembled shift I - J: the Newton matrix is then a shell
        # (NewtonMatrix) that keeps J as assembled at its evaluation, TS's shift and scale as numbers
        newton = self._newton_matrix() if self._shell is not None and pc_type == "python" else None
        rows = slice(*self.x.getOwnershipRange())

        if self.grid is not None:
            def rhs(ts, t, x, f):
                self.grid.rates(x, f)
        else:
            def rhs(ts, t, x, f):
                f.setArray(fun(t, self._gathered(x))[rows])

        def jacobian(ts, t, x, J, P):
            if self._stale(ts):
                self.n_jac += 1
                if self._shell is not None:
                    self._shell.new_jacobian()
                if self.grid is not None and self.grid.has_jacobian:
                    self._values = self.grid.jacobian_slots(x)
                else:
                    Jt = sparse.coo_matrix(problem.jacobian.jac(t, self._gathered(x)))
                    self._values = self._pattern_values(self.order[Jt.row], self.order[Jt.col], Jt.data)
                if newton is not None:
                    self.J.setValuesCOO(self._values, addv=PETSc.InsertMode.INSERT_VALUES)
            if newton is None:
                P.setValuesCOO(self._values, addv=PETSc.InsertMode.INSERT_VALUES)
            else:
                newton.getPythonContext().restore()  # J again, which TS scales and shifts next
            if J.handle != P.handle:  # -snes_mf_operator: J is the matrix-free product of the current state
                J.assemble()

        ts.setRHSFunction(rhs, F)
        ts.setRHSJacobian(jacobian, *(2 * (self.J if newton is None else newton,)))
        ts.setTime(t0)
        self.time_scale = problem.time_scale(t0) if self.grid is None else self._time_scale(t0)
        ts.setTimeStep(first_step if first_step is not None else self.time_scale)
        ts.setMaxTime(1e300)
        ts.setMaxSteps(10**9)
        ts.setExactFinalTime(PETSc.TS.ExactFinalTime.INTERPOLATE)
        ts.setTolerances(rtol=rtol, atol=atol)
        ts.setMaxSNESFailures(-1)  # a failed Newton solve halves the step; the minimum step ends it
        ts.setErrorIfStepFails(False)
        ts.setSolution(self.x)
        # this run's step limits, on its own TS (not the options database, which the next run in this
        # process would inherit); -ts_adapt_dt_min and -ts_adapt_dt_max, read below, override them
        # the minimum relative to the fastest time scale, as on CVODE
        ts.setStepLimits(MIN_STEP_FRACTION * self.time_scale,
                         max_step if np.isfinite(max_step) else ts.getStepLimits()[1])
        ts.setFromOptions()
        pc = ts.getSNES().getKSP().getPC()
        if pc.getType() == "python" and self._shell is not None:
            pc.setPythonContext(self._shell)
        for key in own:
            db.delValue(key)
        ts.setUp()
        self._keep_mass(ts.getSNES())
        return ts

    def _newton_matrix(self):
        """A matrix of type 'python' of this rank's rows: :class:`NewtonMatrix` of the assembled J."""
        rows = self.J.getLocalSize()[0]
        size = ((rows, self._n), (rows, self._n))
        M = self.PETSc.Mat().createPython(size, NewtonMatrix(self.J), comm=self.comm)
        M.setUp()
        M.assemble()  # (TS scales and shifts only an assembled matrix)
        return M

    def _time_scale(self, t0) -> float:
        """The problem's :meth:`~.base.Problem.time_scale` on a grid of blocks, to the same
        number: :func:`~icidr_pde.time_scale.fastest_time_scale` on this rank's block, its
        difference quotients each rank's rates of its own cells, its norms those of the whole
        vectors in the problem's ordering (taken on rank 0, sent to every rank)."""
        grid, x = self.grid, self.x
        f, probe = x.duplicate(), x.duplicate()

        def rates(t, y):
            probe.setArray(y)
            grid.rates(probe, f)
            return np.array(f.getArray(readonly=True))

        def norm(y):
            probe.setArray(y)
            whole = grid.to_root(probe)
            return mpi_ranks.broadcast(float(np.linalg.norm(whole)) if self.comm.rank == 0 else None)

        return fastest_time_scale(rates, t0, np.array(x.getArray(readonly=True)), norm=norm,
                                  index=grid.problem_index())

    def _mass_weights(self):
        """The mass weights c (c J = 0: the scheme conserves c . y) as a vector of the state's
        distribution, or None: the problem's `jacobian.weights`; where it has none but brings
        patches, phi (field 0, the Patches' first) on the DMDA's equal cells (as
        :func:`~.linear.base.cell_mass`), each rank on its own cells."""
        weights = self.problem.jacobian.weights
        if weights is None and self.grid is not None:
            c = self.x.duplicate()
            own = np.zeros(c.getLocalSize())
            own[::self.grid.dof] = 1.0  # the DMDA's fields interleaved, phi first
            c.setArray(own)
            return c
        if weights is None or not np.any(weights):
            return None
        c = self.x.duplicate()
        if self.grid is not None:
            self.grid.scatter_in(weights, c)
        else:
            c.setArray(np.asarray(weights, float)[slice(*self.x.getOwnershipRange())])
        return c

    def _keep_mass(self, snes):
        """Each Newton correction y (x -> x - y) is corrected by a multiple of q (c q = 1) so that
        the new iterate has the initial mass: c . (x - y) = c . y0.

        The exact solution of each step's nonlinear system has that mass to round-off (c J = 0,
        and BDF's weights of the past states sum to 1), and so has the exact Newton correction;
        GMRES's correction carries its residual's share of mass (ksp_rtol of the correction),
        which the next Newton iteration removes but a step's last correction leaves in the state.
        Where a step takes one Newton iteration (the long steps of a slow phase) that is each
        step's drift. Set on the correction rather than in the preconditioner (as the serial
        :func:`~.linear.precond.mass_keeping_precond` does): the operator's products by difference
        quotients (snes_mf_operator) do not keep the Krylov vectors' mass exactly, and the
        correction costs one reduction over the ranks per Newton iteration (the two sums in one,
        PETSc's split reduction), not one per GMRES iteration. The target is the initial mass,
        not the last state's, so round-off does not accumulate over the steps."""
        c = self._mass_weights()
        if c is None:
            return
        q = c.copy()
        q.scale(1.0 / c.dot(c))
        target = c.dot(self.x)

        def correct(x, y):
            c.dotBegin(x)
            c.dotBegin(y)
            mass_x, mass_y = c.dotEnd(x), c.dotEnd(y)
            y.axpy(mass_x - target - mass_y, q)
            return True  # y changed (the line search is told)

        snes.setLineSearchPreCheck(correct)

    def _stale(self, ts) -> bool:
        """Whether the kept Jacobian values are too old: JAC_MAX_AGE steps, or a step rejected or
        a Newton solve failed since they were evaluated."""
        now = (ts.getStepNumber(), ts.getStepRejections(), ts.getSNESFailures())
        if self._values is None or now[0] - self._evaluated[0] >= JAC_MAX_AGE or now[1:] != self._evaluated[1:]:
            self._evaluated = now
            return True
        return False

    def _pattern_values(self, rows, cols, data) -> np.ndarray:
        """Jacobian entries (rows, cols, data) in PETSc's ordering, entries of one position
        summed, as values in this rank's pattern order (COO); entries of other ranks' rows are
        left out."""
        keys = rows.astype(np.int64) * self._n + cols
        if self._last_keys is None or not np.array_equal(keys, self._last_keys):
            pos = np.searchsorted(self._keys, keys)
            mine = (pos < self._keys.size) & (self._keys[np.minimum(pos, self._keys.size - 1)] == keys)
            self._last_keys, self._map = keys, (pos[mine], mine)
        pos, mine = self._map
        # summed in the order of the entries, as np.add.at sums them, at a fraction of its cost
        return np.bincount(pos, weights=data[mine], minlength=self._keys.size)

    def advance(self, t_end):
        with mpi_ranks.noting_signals():
            return self._advance(t_end)

    def _advance(self, t_end):
        PETSc, ts = self.PETSc, self.ts
        while self.t < t_end:
            try:
                ts.step()
            except PETSc.Error as err:  # an interrupt inside a callback reaches here as PETSc's error
                if isinstance(err.__cause__, KeyboardInterrupt):
                    raise err.__cause__ from None
                raise
            reason = ts.getConvergedReason()
            if reason < 0:
                why = f"integrator failed (PETSc TS: {_reason_name(PETSc, reason)}, dt = {ts.getTimeStep():.3g})"
                return self.t, self._gathered(self._good), why
            if self._invalid_anywhere():  # the problem's check says why, on the gathered state
                y = self._gathered(self.x)
                why = self.problem.check(y) if not self.blocks else mpi_ranks.broadcast(
                    self.problem.check(y) if self.comm.rank == 0 else None)
                if why:
                    return float(ts.getTime()), y, why
            self.t = float(ts.getTime())
            self.x.copy(self._good)
        return None

    def _invalid_anywhere(self) -> bool:
        """After a step, on every rank alike: whether the accepted state is invalid (the
        problem's check: non-finite, phi out of range), each rank testing its own block, by one
        reduction over the ranks (a problem without patches: its check of the gathered state).
        A SIGINT or SIGTERM any rank received during the step is delivered here on every rank
        (by the same reduction)."""
        if self._inside is not None:
            invalid = not self._inside(self.x.getArray(readonly=True))
        else:
            invalid = self.problem.check(self._gathered(self.x)) is not None
        if self.ranks == 1:
            return invalid
        self._flags.setArray([SIGNAL_WEIGHT * mpi_ranks.pending() + invalid])
        flag = int(self._flags.max()[1])
        if flag >= SIGNAL_WEIGHT:
            mpi_ranks.deliver(flag // SIGNAL_WEIGHT)
        return bool(flag)

    def _at(self, t):
        """The state at t inside the last step, distributed (TS's solution or its interpolant)."""
        if t >= self.t:
            return self.x
        self.ts.interpolate(t, self._work)
        return self._work

    def value_at(self, t):
        return self._gathered(self._at(t))

    def advance_outputs(self, times, store, max_w, states, measure):
        """As :meth:`Engine.advance_outputs`; max|w| by a reduction over the ranks' blocks, the
        state gathered only where it is kept (store[k] >= 0: the snapshots, the last output)."""
        field = None if self.grid is None else self.grid.patches.measured
        with mpi_ranks.noting_signals():
            for k, t in enumerate(times):
                failure = self._advance(t)
                if failure is not None:
                    return k, failure
                v = self._at(t)
                y = self._gathered(v) if store[k] >= 0 or field is None else None
                max_w[k] = measure(y) if field is None else v.strideNorm(field, self.PETSc.NormType.INFINITY)
                if store[k] >= 0:
                    states[store[k]] = y
                v.copy(self._kept)
                self._kept_t, self._kept_y = float(t), y
        return len(times), None

    def last_good(self):
        """(t, y) of the last output reached; its state gathered at the first call (on every rank:
        the run path calls it on each alike, after an interrupt the ranks agreed on)."""
        if self._kept_y is None:
            self._kept_y = self._gathered(self._kept)
        return self._kept_t, self._kept_y

    def last_step(self):
        """(t, y) of the last accepted step that passed the check (``self.t`` and ``_good``, where
        every rank stops alike after an interrupt), its state gathered (called on every rank, as
        :meth:`last_good`)."""
        return self.t, self._gathered(self._good)

    def last_step_time(self) -> float:
        """The time of :meth:`last_step`, nothing gathered."""
        return self.t

    def counts(self):
        return int(self.ts.getStepNumber()), self.n_jac, None


#: a signal's number weighs this much in the per-step reduction of (signal, invalid state)
SIGNAL_WEIGHT = 64


def block_problem(PETSc, patches, initial_block, check, comm=None, proc_sizes=None):
    """(Problem, BlockGrid) of a scheme's `patches` on the DMDA's blocks, each rank's its own: its
    y0 the rank's block of the initial data, ``initial_block(((xs, xe), (zs, ze)))`` -> (dof,
    mx, mz), the Jacobian's pattern and values its rows' (the patch Jacobian), `check` the
    problem's check of a whole state (on rank 0: why a state is invalid). The engine given it
    builds nothing of the whole grid. `proc_sizes`: the DMDA's ranks along (x, z), as the linear
    solver asks (:meth:`BlockGrid`'s; None: PETSc's choice)."""
    from .base import JacobianSpec

    if patches.jacobian is None:
        raise ValueError("a problem of blocks needs the scheme's patch Jacobian")
    grid = BlockGrid(PETSc, patches, comm or PETSc.COMM_WORLD, proc_sizes)
    y0 = grid.block(initial_block(grid.ranges))
    return Problem(y0=y0, fun=None, jacobian=JacobianSpec("sparse"), check=check, patches=grid), grid


class NewtonMatrix:
    """petsc4py's context of a matrix of type 'python': TS's Newton matrix, weight J + diagonal I,
    with J the assembled Jacobian of f (an AIJ matrix, its values set once per evaluation) and
    TS's scale and shift kept as the two numbers. TS forms each Newton system's matrix from J by
    MatScale(-1) and MatShift(shift): on an assembled shift I - J that is a pass over every entry,
    after the Jacobian's values were set again (TS scaled them), at every Newton system; here
    it is two multiplications. Its products and diagonal are J's, weighted and shifted; the
    x-Fourier shell reads the numbers and averages J itself (:mod:`.linear.xfourier_shell`)."""

    def __init__(self, jacobian):
        self.jacobian = jacobian
        self.weight, self.diagonal = 1.0, 0.0

    def restore(self):
        """The matrix is J again (as TS's Jacobian callback leaves it)."""
        self.weight, self.diagonal = 1.0, 0.0

    def scale(self, mat, alpha):
        self.weight *= alpha
        self.diagonal *= alpha

    def shift(self, mat, alpha):
        self.diagonal += alpha

    def mult(self, mat, x, y):
        self.jacobian.mult(x, y)
        y.scale(self.weight)
        y.axpy(self.diagonal, x)

    def getDiagonal(self, mat, d):
        self.jacobian.getDiagonal(d)
        d.scale(self.weight)
        d.shift(self.diagonal)


@njit(cache=True)
def _stencil_slots(indptr, indices, data, mx, mz, gx, gz, side, dof, out):
    """out[slot] += each entry of the patch Jacobian (CSR: rows the block's own unknowns (field,
    i, j), columns the ghosted patch's (field', gi, gj)), slot ((row side + gi - i) side + gj -
    j) dof + field' (:meth:`BlockGrid.stencil_pattern`); returns the number of entries beyond
    the stencil."""
    outside = 0
    for r in range(indptr.size - 1):
        i = (r // mz) % mx
        j = r % mz
        for e in range(indptr[r], indptr[r + 1]):
            c = indices[e]
            field = c // (gx * gz)
            a = (c // gz) % gx - i
            b = c % gz - j
            if a < 0 or a >= side or b < 0 or b >= side:
                outside += 1
                continue
            out[((r * side + a) * side + b) * dof + field] += data[e]
    return outside


def _sorted_unique(keys) -> np.ndarray:
    """np.unique(keys) by one sort in place: numpy's unique (a hash table, then the sort) took
    several times as long on the millions of a Jacobian's pattern."""
    keys.sort()
    return keys[np.concatenate(([True], keys[1:] != keys[:-1]))] if keys.size else keys


def _reason_name(PETSc, reason) -> str:
    names = {v: k for k, v in vars(PETSc.TS.ConvergedReason).items() if isinstance(v, int)}
    return names.get(reason, str(reason))


class BlockGrid:
    """The 2-D grid of a problem's :class:`~icidr_pde.cells.plane2d.pde.Patches` as a
    PETSc DMDA: x periodic, z bounded with ghost rows beyond the walls (DM_BOUNDARY_GHOSTED,
    filled by the scheme from its wall conditions), the `dof` fields interleaved, a box stencil
    of the scheme's width. Each rank owns a block of cells; its right-hand side is the patch
    kernel on its block and one ghost layer (globalToLocal), nothing else is communicated.

    The problem's vector is the data (dof, nx, nz) flattened; PETSc's is the DMDA's (per rank
    block, then z, x, field). What a rank builds here is of its own block's size (its patch's
    global indices from the DMDA's local-to-global map, its rows' Jacobian pattern); the
    whole-grid maps (``order``: PETSc's index of each of the problem's unknowns, ``gathered``:
    the whole vector on every rank) are built only where asked (tests, a problem without block
    data), :meth:`to_root` gathers on rank 0 alone. `proc_sizes` (ranks along x, along z):
    PETSc's choice where None.
    """

    def __init__(self, PETSc, patches, comm, proc_sizes=None):
        nx, nz = patches.shape
        dof, width = patches.dof, patches.stencil
        B = PETSc.DM.BoundaryType
        kinds = tuple(B.PERIODIC if p else B.GHOSTED for p in patches.periodic)
        self.PETSc, self.patches, self.shape, self.dof, self.width = PETSc, patches, (nx, nz), dof, width
        try:
            self.da = PETSc.DMDA().create(dim=2, dof=dof, sizes=(nx, nz), boundary_type=kinds,
                                          stencil_type=PETSc.DMDA.StencilType.BOX, stencil_width=width,
                                          proc_sizes=proc_sizes, comm=comm)
        except PETSc.Error as err:  # the same on every rank: the split is computed by each alike
            if err.ierr != PETSC_ERR_ARG_OUTOFRANGE:
                raise
            P = comm.size
            raise ParameterError(f"`N` must be a grid that {P} MPI ranks can split into blocks of at least "
                                 f"{width} x {width} cells (PETSc's DMDA; at least {width * P} x {width * P} "
                                 f"cells always can); got ({nx}, {nz})") from None
        (xs, xe), (zs, ze) = self.ranges = self.da.getRanges()
        (gxs, gxe), (gzs, gze) = self.da.getGhostRanges()
        if (gxe - gxs, gze - gzs) != (xe - xs + 2 * width, ze - zs + 2 * width):
            raise ValueError(f"a block of the {nx} x {nz} grid has no full ghost layer: "
                             f"cells x {xs}:{xe}, z {zs}:{ze}, with ghosts x {gxs}:{gxe}, z {gzs}:{gze}")
        self.owned = (xe - xs, ze - zs)
        self.ghosted = (gxe - gxs, gze - gzs)
        self.low, self.high = zs == 0, ze == nz
        self.local = self.da.createLocalVec()
        self.out = np.empty((dof, xe - xs, ze - zs))
        self.has_jacobian = patches.jacobian is not None
        # PETSc's index of each value of this rank's patch (-1 beyond a wall) and of its cells: the
        # DMDA's local-to-global map of the ghosted block (z, x, field), as the patch (field, x, z)
        ghosted = np.asarray(self.da.getLGMap().getIndices(), dtype=np.int64)
        patch = ghosted.reshape(gze - gzs, gxe - gxs, dof).transpose(2, 1, 0)
        self.columns = np.where(patch >= 0, patch, -1).ravel()
        self.rows = self.columns.reshape(patch.shape)[:, width:-width, width:-width].ravel()
        self._natural = self._root = self._all = None

    @functools.cached_property
    def order(self) -> np.ndarray:
        """PETSc's index of each of the problem's unknowns (the whole grid's, on every rank: built
        where asked, by the DMDA's application ordering)."""
        nx, nz = self.shape
        k, i, j = np.meshgrid(np.arange(self.dof), np.arange(nx), np.arange(nz), indexing="ij")
        natural = ((j * nx + i) * self.dof + k).ravel().astype(self.PETSc.IntType)
        return np.asarray(self.da.getAO().app2petsc(natural.copy()), dtype=np.int64)

    def problem_index(self) -> np.ndarray:
        """The problem's index ((field nx + i) nz + j) of each of this rank's values, in PETSc's order."""
        nx, nz = self.shape
        (xs, xe), (zs, ze) = self.ranges
        j, i, k = np.meshgrid(np.arange(zs, ze), np.arange(xs, xe), np.arange(self.dof), indexing="ij")
        return ((k * nx + i) * nz + j).ravel()

    def _patch(self, x) -> np.ndarray:
        """This rank's patch (dof, mx + 2, mz + 2) of the global vector x."""
        self.da.globalToLocal(x, self.local, addv=self.PETSc.InsertMode.INSERT_VALUES)
        gx, gz = self.ghosted
        return np.ascontiguousarray(self.local.getArray(readonly=True).reshape(gz, gx, self.dof).transpose(2, 1, 0))

    def stencil_pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) in PETSc's ordering: the Jacobian's pattern on this rank's rows, every field
        of each own cell coupled to every field of the cells within the stencil's width around it
        (x periodic; beyond a wall nothing, the ghost row being folded onto the edge row, which is
        in it), as the whole grid's pattern (the scheme's ``jacobian_sparsity``). One slot per (own
        unknown, x-offset, z-offset, field of the column), the unknowns in the order of
        :attr:`rows`, so that an entry's slot is arithmetic (:meth:`jacobian_slots`), not searched;
        a slot beyond a wall has column -1 (PETSc's COO leaves it out)."""
        dof, w = self.dof, self.width
        (mx, mz), (gx, gz) = self.owned, self.ghosted
        side = 2 * w + 1
        windows = np.lib.stride_tricks.sliding_window_view(self.columns.reshape(dof, gx, gz), (side, side),
                                                           axis=(1, 2))  # [field', i, j, a, b]
        cols = np.broadcast_to(windows.transpose(1, 2, 3, 4, 0)[None], (dof, mx, mz, side, side, dof))
        rows = np.broadcast_to(self.rows.reshape(dof, mx, mz, 1, 1, 1), cols.shape)
        return rows.ravel(), cols.ravel()

    def pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols): the slots of :meth:`stencil_pattern` inside the walls."""
        rows, cols = self.stencil_pattern()
        inside = cols >= 0
        return rows[inside], cols[inside]

    def jacobian_rows(self, x):
        """(rows, cols, values) in PETSc's ordering: the Jacobian rows of this rank's cells, the
        values of :meth:`jacobian_slots` on :meth:`pattern`."""
        rows, cols = self.stencil_pattern()
        inside = cols >= 0
        return rows[inside], cols[inside], self.jacobian_slots(x)[inside]

    def jacobian_slots(self, x) -> np.ndarray:
        """The Jacobian rows of this rank's cells, from its patch alone, as values of the slots of
        :meth:`stencil_pattern`, entries of one slot summed in their order."""
        Jp = self.patches.jacobian(self._patch(x), self.low, self.high).tocsr()
        (mx, mz), (gx, gz) = self.owned, self.ghosted
        out = np.zeros(self.rows.size * (2 * self.width + 1) ** 2 * self.dof)
        outside = _stencil_slots(Jp.indptr, Jp.indices, Jp.data, mx, mz, gx, gz, 2 * self.width + 1, self.dof, out)
        if outside:
            raise ValueError(f"{outside} couplings of the patch Jacobian reach beyond the stencil of width {self.width}")
        return out

    def rates(self, x, f):
        """f = the scheme's rates of the global vector x, each rank on its own block."""
        self.patches.rates(self._patch(x), self.low, self.high, self.out)
        mx, mz = self.owned
        f.getArray().reshape(mz, mx, self.dof)[...] = self.out.transpose(2, 1, 0)  # one copy, into f's own memory

    def block(self, data) -> np.ndarray:
        """This rank's values in PETSc's order (the global vector's local part) of its block's
        data (dof, mx, mz)."""
        return np.ascontiguousarray(np.asarray(data, float).transpose(2, 1, 0)).ravel()

    @property
    def natural(self):
        if self._natural is None:
            self._natural = self.da.createNaturalVec()
        return self._natural

    def scatter_in(self, y, x):
        """The global vector x of the problem's vector y (the whole vector, the same on every rank)."""
        start, end = self.natural.getOwnershipRange()
        nx, nz = self.shape
        self.natural.setArray(np.asarray(y, float).reshape(self.dof, nx, nz).transpose(2, 1, 0).ravel()[start:end])
        self.da.naturalToGlobal(self.natural, x, addv=self.PETSc.InsertMode.INSERT_VALUES)

    def _whole(self, x, scatter, full) -> np.ndarray:
        self.da.globalToNatural(x, self.natural, addv=self.PETSc.InsertMode.INSERT_VALUES)
        scatter.scatter(self.natural, full, addv=self.PETSc.InsertMode.INSERT, mode=self.PETSc.ScatterMode.FORWARD)
        nx, nz = self.shape
        values = full.getArray(readonly=True)
        out = np.empty(values.size)
        if values.size:
            out.reshape(self.dof, nx, nz)[...] = values.reshape(nz, nx, self.dof).transpose(2, 1, 0)
        return out

    def gathered(self, x) -> np.ndarray:
        """The problem's vector of the global vector x, on every rank."""
        if self._all is None:
            self._all = self.PETSc.Scatter.toAll(self.natural)
        return self._whole(x, *self._all)

    def to_root(self, x) -> np.ndarray:
        """The problem's vector of the global vector x on rank 0 (what its outputs keep), an
        empty array on the other ranks."""
        if self._root is None:
            self._root = self.PETSc.Scatter.toZero(self.natural)
        return self._whole(x, *self._root)
