"""One run path: validate, choose the engine, build the case, integrate, assemble the Result.

:func:`run` checks every argument once, resolves the preset once, asks
:func:`~icidr_pde.engines.choose.choose` once for the engine, Jacobian and linear solver,
builds the case once (:func:`~icidr_pde.case.build_case`), sets up the engine's
:class:`~icidr_pde.engines.base.Problem` (the native engine's compiled one, or the py-pde
scheme's), advances the engine through the merged output times of the schedule
(:func:`~icidr_pde.drive.drive`, the same for every engine: the native one many outputs per call
into C) and builds the Result by :func:`assemble`. What a run writes or shows besides the Result
(a snapshot file, movie frames, a live plot) and a wall-clock limit are recorders
(:mod:`icidr_pde.recorders`), called at their output times on every engine. Light: a run on the
native engine without recorders imports neither py-pde, numba, scipy, sympy nor scikit-sundae.
"""

from __future__ import annotations

import sys
import time as _time
import warnings

import numpy as np

from .drive import Outcome, Recorded, View, drive, outcome as _outcome, recorded as _recorded
from .engines.base import check_tolerances
from .engines.choose import Choice, choose
from .presets import resolve
from .recorders import StopRun, WallClock, make_recorders
from .result import Fields, Result
from .rheology import Material
from .schedule import Schedule, schedule
from .scenes import SCENES, Scene
from .times import check_t_end
from .validation import check_atol, output_path, real

__all__ = ["run", "make_pde", "DISCRETIZATIONS", "make_recorders", "StopRun", "WallClock", "Outcome", "Schedule",
           "schedule"]


def __getattr__(name):  # py-pde is imported only by the runs that take it
    if name == "make_pde":
        from .case import make_pde

        return make_pde
    if name == "DISCRETIZATIONS":
        from .discretizations import DISCRETIZATIONS

        return DISCRETIZATIONS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def assemble(*, rheology: str, scene, discretization: str, N: int, z, mass, material: dict, t_end: float,
             rtol: float, atol: float, method: str, choice: Choice, accuracy, options: dict, labels: list,
             recorded: Recorded, outcome: Outcome, counts: tuple, y0_data, plane: dict | None = None,
             ranks: int = 1) -> Result:
    """The Result of a run of any engine: what it recorded, how it ended, its counts (steps,
    RHS, Jacobians, LUs) and its settings (the options of the scheme, engine, linear solver
    and Jacobian of the choice, and `ranks`: the number of MPI processes that computed it, 1
    but for the PETSc engine under mpiexec)."""
    series = recorded.max_w_t is not None  # None: no series asked, none appended at t* either
    max_w_t, max_w = (list(recorded.max_w_t), list(recorded.max_w)) if series else ([], [])
    if outcome.blew_up and series:
        max_w_t.append(float(outcome.t_star))
        max_w.append(float(np.max(np.abs(outcome.final[2]))))
    chi_kwargs = {}
    if len(recorded.chi_t):
        chi_kwargs = dict(chi_t=np.asarray(recorded.chi_t, float), chi_z=recorded.chi_z, chi=np.asarray(recorded.chi))
    data, n_snap = recorded.data, recorded.data.shape[0]
    mass0 = mass(y0_data)
    n_steps, n_rhs, n_jac, n_lu = counts
    return Result(
        rheology=rheology, scene=scene.name, discretization=discretization, N=N, t_end=float(t_end),
        rtol=float(rtol), atol=float(atol), method=method, jacobian=choice.jacobian, blew_up=outcome.blew_up,
        t_star=outcome.t_star, reason=outcome.reason, t_final=float(outcome.t_final), z=z,
        times=np.asarray(recorded.times, float), time_labels=labels[:n_snap], requested_times=labels,
        phi=data[:, 0], u=data[:, 1], w=data[:, 2], final=Fields(*outcome.final),
        max_w_t=np.array(max_w_t), max_w_series=np.array(max_w),
        last_times=recorded.last_times,
        last_states=recorded.last_states if recorded.last_states is not None else data[:0],
        mass_drift=(mass(outcome.final) - mass0) / mass0,
        wall_s=outcome.wall_s, compile_s=outcome.compile_s, cpu_s=outcome.cpu_s, n_steps=n_steps, n_rhs=n_rhs,
        n_jac=n_jac, n_lu=n_lu, scene_params=scene.parameters(), material=material,
        settings=dict(accuracy=accuracy, **options, engine=choice.engine, linear_solver=choice.linear_solver,
                      jacobian=choice.jacobian, max_order=choice.max_order, ranks=int(ranks)),
        **chi_kwargs, **(plane or {}),
    )


def run(
    rheology: str = "icidr",
    scene: str = "shear",
    N: int | None = None,
    t_end: float = 10.0,
    times=None,
    *,
    accuracy: str = "standard",
    discretization: str | None = None,
    method: str | None = None,
    rtol: float | None = None,
    atol: float | None = None,
    jacobian: str | None = None,
    max_order: int | None = None,
    material: Material | None = None,
    advection: str | None = None,
    progress: bool = False,
    live_plot: bool = False,
    save: str | None = None,
    movie: str | None = None,
    frame_dt: float | None = None,
    series_times=None,
    backend: str = "numba",
    max_wall: float | None = None,
    engine: str = "auto",
    on_result=None,
    **scene_params,
) -> Result:
    """Run `scene` with `rheology` and return a :class:`~icidr_pde.result.Result`.

    Args:
        rheology: a registered rheology: 'mui' ((3.13)-(3.15)) or 'icidr' ((5.3)-(5.5)
            with the pressure (4.12))
        scene: a registered scene: 'shear' (IC (3.16)) or 'sine' (IC (5.7)); scene
            parameters (phi0, eps, a, b, H) are keyword arguments
        N: number of grid cells ('fd') or collocation points with walls ('cheb'); on the 2-D
            cell (plane2d) Nz or the pair (Nx, Nz)
        t_end: final time
        times: snapshot times (strings keep their spelling as labels)
        accuracy: preset 'draft', 'standard' or 'publication' (see :mod:`icidr_pde.presets`);
            it fills in discretization, N, method, rtol and atol where they are None
        discretization: a registered scheme: 'fd' (finite volumes on py-pde's grid) or
            'cheb' (Chebyshev)
        method: 'BDF', 'Radau', 'LSODA' (scipy) or 'CVODE' (SUNDIALS, the fast path)
        rtol, atol: integrator tolerances
        jacobian: 'analytic', 'sparse-fd', 'banded-fd' or 'none' (None: the method's default)
        max_order: the highest BDF order (1-5) of CVODE and PETSc; None: 2 on the 2-D cell (A-stable:
            no advected wave that the continuum damps is amplified), 5 on the 1-D cells (their
            spectrum lies inside BDF5's stability sector); a higher order on the 2-D cell, or scipy's
            BDF/LSODA there (no cap), is run with a warning (:func:`~icidr_pde.engines.choose.time_order`)
        material: laws and parameters (default Table 1)
        advection: 'upwind' or 'central' (an option of 'fd'; None: the scheme's default)
        progress: show a progress bar (tqdm.auto; see :class:`~icidr_pde.progress.TimeBar`)
        live_plot: one figure of the fields updated in place while they evolve, redrawn within
            ~10 % of the wall time (:class:`~icidr_pde.live_plot.LivePlot`), Jupyter or a window
        save: optional HDF5 file for the snapshots (py-pde FileStorage layout plus the node
            positions `z`; read it with :func:`icidr_pde.snapshots.read_snapshots`)
        movie: optional .mp4 (or .gif) file: a movie of the run (:mod:`icidr_pde.movies`)
        frame_dt: interval of simulated time between movie frames, independent of `times`
            (None: 40 log-spaced frames up to t_end/200, then every t_end/200)
        series_times: times of the max|w| series (default: dense log+linear; empty: none)
        backend: 'numba' (compiled kernels, cached on disk) or 'numpy'
        max_wall: abandon the run after this many seconds (reason 'timeout ...')
        engine: 'auto' (default, as the CLI's --engine), 'native' or 'pde': 'auto' and 'native'
            take the native engine (:mod:`icidr_pde.engines.native`: C kernels and CVODE, no Python
            in the loop) where it applies (CVODE with the Jacobian its cell states: analytic on the
            1-D cell, matrix-free GMRES on the 2-D one; :attr:`~icidr_pde.cells.base.Cell.native`),
            with every output and recorder, else a Python engine on the py-pde scheme (scipy or scikit-sundae);
            'native' says on stderr why it fell back; 'pde' is always the Python engines (the ones
            the regression anchors are pinned on). All return the same Result fields, and the
            settings name the engine, linear solver and Jacobian; CVODE's step choices may differ
            by round-off (docs/engines.md)
        on_result: called with the Result once the run has ended and before the movie is
            rendered (the CLI writes --json and --plot there: an interrupt while the movie is
            rendered loses neither)

    Outputs (`save`, `movie`) are written whole or not at all (:mod:`icidr_pde.outputs`); one
    that cannot be written (a full disk, an interrupt while the movie is rendered) does not
    stop the run: the Result's `not_written` says which and why (with a RuntimeWarning).

    A failed run (step-size underflow, non-finite state, phi leaving its inertial range) is
    not an exception: the Result has blew_up=True, t_star, reason, and all that was recorded.
    """
    # every argument is checked once, before any work and before any output file is touched
    t_end = check_t_end(t_end)
    save, movie = output_path("save", save), output_path("movie", movie)
    frame_dt = None if frame_dt is None else real("frame_dt", frame_dt, 0)
    scene_cls = scene if isinstance(scene, Scene) else SCENES.get(scene)
    if discretization is None:  # a scene of the 2-D cell names its scheme
        discretization = getattr(scene_cls, "discretization", None)
    settings = resolve(accuracy, discretization=discretization, N=N, method=method, rtol=rtol, atol=atol)
    settings["rtol"], settings["atol"] = check_tolerances(settings["rtol"], settings["atol"])
    settings["atol_asked"] = atol is not None
    ask = dict(method=settings["method"], jacobian=jacobian, request=engine, backend=backend, max_order=max_order,
               **_cell_ask(settings["discretization"], scene, scene_cls, settings["N"], scene_params, engine))
    choice = choose(**ask)
    if choice.warning:
        sys.stderr.write(f"icidr-pde: warning: {choice.warning}\n")
    if choice.engine != "native" and engine == "native":
        sys.stderr.write(f"icidr-pde: native engine not used: {choice.reason}; running the py-pde path\n")
    from .case import build_case

    outputs = dict(save=save, live_plot=live_plot, movie=movie, frame_dt=frame_dt, max_wall=max_wall)
    options = {} if advection is None else {"advection": advection}
    core = None
    if choice.engine == "native":
        from .native import NativeUnavailable
        from .native_case import core_class

        core = core_class(settings["discretization"])
    case = build_case(rheology, scene, settings["discretization"], settings["N"], material=material,
                      options=options, scene_params=scene_params, core=core,
                      check_grid=lambda pde, grid: _check_memory(pde, grid, settings, choice))
    run_case = dict(accuracy=accuracy, progress=progress, series_times=series_times, backend=backend,
                    outputs=outputs)
    if choice.engine == "native":
        try:
            result, recorders = _run(case, choice, settings, t_end, times, **run_case)
        except NativeUnavailable as err:
            sys.stderr.write(f"icidr-pde: native engine not available ({err}); running the py-pde path\n")
            choice = choose(**dict(ask, native_unavailable=str(err)))
            # the case of the py-pde path: the native engine's is on the core its cell names
            case = build_case(rheology, scene, settings["discretization"], settings["N"], material=material,
                              options=options, scene_params=scene_params,
                              check_grid=lambda pde, grid: _check_memory(pde, grid, settings, choice))
            result, recorders = _run(case, choice, settings, t_end, times, **run_case)
    else:
        result, recorders = _run(case, choice, settings, t_end, times, **run_case)
    return _finish(result, recorders, save, movie, on_result)


def _finish(result: Result, recorders, save, movie, on_result) -> Result:
    """After the timing: what the recorders could not write, the caller's `on_result`, then the movie."""
    for recorder in recorders:
        if getattr(recorder, "error", None) is not None:  # the snapshot file
            _not_written(result, "save", save, recorder.error)
    if on_result is not None:
        on_result(result)
    for recorder in recorders:
        if hasattr(recorder, "write"):  # the movie, after the timing: wall_s is the solve and the recorders
            try:
                recorder.write()
            except KeyboardInterrupt:  # the run's results stay; the movie is left as it was
                _not_written(result, "movie", movie, "interrupted")
            except OSError as err:
                _not_written(result, "movie", movie, err.strerror or str(err))
    return result


def _check_memory(pde, grid, settings, choice) -> None:
    from .engines.stiff import check_memory

    check_memory(pde, grid, settings["method"], choice)


def _run(case, choice: Choice, settings, t_end, times, *, accuracy, progress, series_times, backend, outputs):
    """The run of `case` on the engine of `choice`: its Problem set up (timed as compile_s), the
    recorders of `outputs` (:func:`~icidr_pde.recorders.make_recorders`), the drive loop through the
    schedule, the Outcome and the Result. Returns (Result, recorders). The native engine raises
    NativeUnavailable before any work where its library cannot be built or the run is too stiff
    for it."""
    from .engines import engine_class
    from .heap import keep_freed_arrays

    keep_freed_arrays()  # a step's grid-sized arrays reused, not faulted in again (heap.py)
    set_up = (_native_set_up if choice.engine == "native" else _blocks_set_up if _on_blocks(case, choice)
              else _scheme_set_up)
    if set_up is not _blocks_set_up:  # there each rank checks its own block (no rank holds the whole state)
        check_atol(settings["atol"], case.initial, settings["atol_asked"])
    sched = schedule(case.scene, t_end, times, series_times=series_times)
    bar = None
    if progress:
        from .progress import TimeBar

        # refreshed every 0.1 s also into a pipe, as tqdm does by default: a reader sees the time move
        bar = TimeBar(t_end, "compiling", log_interval=0.1)
    start, cpu_start = _time.perf_counter(), _time.process_time()
    recorders = []
    try:
        view, counted, note = set_up(case, choice, settings, t_end, backend)
        if not view.root:  # what a run writes or shows is rank 0's, where the whole states are
            outputs = dict(outputs, save=None, live_plot=False, movie=None)
        recorders = make_recorders(case, t_end, snap_times=sched.snap_times, progress=progress, chi=view.chi,
                                   **outputs)
    except BaseException:
        for recorder in recorders:
            recorder.abandon()
        if bar is not None:
            bar.discard()
        raise
    compile_s, compile_cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    if bar is not None:
        bar.integrating(note(compile_s))

    def make_engine():
        return engine_class(choice.engine)(settings["method"], view.problem, 0.0, rtol=settings["rtol"],
                                           atol=settings["atol"], linear_solver=choice.solver or choice.linear_solver,
                                           max_order=choice.max_order)

    out, n_done, failure, engine, recording = drive(view, make_engine, sched, t_end, bar, recorders)
    wall = _time.perf_counter() - start - compile_s
    cpu = _time.process_time() - cpu_start - compile_cpu
    outcome = _outcome(view, engine, out, n_done, failure, t_end, wall, compile_s, cpu, recording.stop)
    recording.close(outcome)
    method, ranks, steps_jac_lu = settings["method"], 1, (0, 0, 0)
    if choice.engine == "petsc":  # PETSc's TS integrates whatever method was asked (choose.PETSC_METHOD)
        from .engines.choose import PETSC_METHOD

        method = PETSC_METHOD
    if engine is not None:
        steps_jac_lu = engine.counts()
        choice = choice.solved_by(engine.linear_solver)
        method, ranks = engine.ran or method, engine.ranks
    n_steps, n_jac, n_lu = steps_jac_lu
    if not view.root:  # no whole state here: rank 0's Result, without its fields (View.shared)
        return view.shared(None), recorders
    recorded = _recorded(view, sched, out, n_done)
    result = assemble(rheology=case.rheology.name, scene=case.scene, discretization=case.discretization, N=case.N,
                      z=case.nodes(), mass=case.mass, material=case.rheology.material.to_dict(), t_end=t_end,
                      rtol=settings["rtol"], atol=settings["atol"], method=method, choice=choice,
                      accuracy=accuracy, options=case.options, labels=sched.labels, recorded=recorded,
                      outcome=outcome, counts=(n_steps, counted(), n_jac, n_lu), y0_data=case.initial,
                      plane=case.plane(recorded.data), ranks=ranks)
    return view.shared(result), recorders


def _native_set_up(case, choice, settings, t_end, backend):
    """(View, rates counted, the bar's note) of the native engine on `case`: its compiled problem
    (:mod:`icidr_pde.native`) behind a Problem (:func:`~icidr_pde.engines.native.native_problem`)."""
    from .engines.native import native_problem
    from .native_case import compiled_problem
    from .rheology.base import chi_of_M

    compiled = compiled_problem(case)
    _check_stiffness(compiled, case.y0, t_end)
    problem = native_problem(compiled, case.y0, case.check_state, choice.jacobian)

    def chi(data):  # (A18) with the compiled law's M(phi)
        z_f, phi_f, uz, wz = case.strain_rates(data)
        return z_f, chi_of_M(compiled.M(phi_f), uz, wz)

    view = View(case, problem, case.fields, lambda y: case.fields(compiled.rates(y)), chi)
    return view, lambda: compiled.counts()["rhs"], lambda compile_s: f"native, ready in {compile_s:.2g} s"


def _scheme_set_up(case, choice, settings, t_end, backend):
    """(View, rates counted, the bar's note) of a Python engine (scipy, scikit-sundae, PETSc) on the
    py-pde scheme of `case` (:func:`~icidr_pde.engines.stiff.scheme_problem`), its kernels compiled
    or loaded now."""
    from .engines.base import StepStatistics
    from .engines.stiff import StiffSolver, check_memory, scheme_problem

    check_memory(case.pde, case.grid, settings["method"], choice)  # before the engine allocates
    stats = StepStatistics()
    rhs = StiffSolver(case.pde, method=settings["method"], rtol=settings["rtol"], atol=settings["atol"],
                      backend=backend, choice=choice).rates(case.state)
    rhs(np.array(case.state.data), 0.0)  # compile or load now, so that it counts as set-up time
    problem, ordering = scheme_problem(case.pde, case.state, choice, rhs, stats)
    _compile_jacobian(problem)

    def chi(data):
        z, phi, uz, wz = case.strain_rates(data)
        return z, case.rheology.chi(phi, uz, wz)

    view = View(case, problem, ordering.to_native, lambda y: ordering.rhs(ordering.to_native(y), 0.0), chi)
    return view, lambda: stats.n_rhs, lambda compile_s: f"compiled in {compile_s:.1f} s"


def _on_blocks(case, choice) -> bool:
    """Whether the run is the PETSc engine's on the blocks of the py-pde scheme's grid (the
    scheme offers patches: :func:`_blocks_set_up`)."""
    return choice.engine == "petsc" and case.scheme is None and hasattr(case.pde, "patches")


class _BlocksView(View):
    """The run path's view of a run distributed by blocks (:func:`_blocks_set_up`): the whole
    initial vector `y0` on rank 0 (an empty one elsewhere), the fields of a whole vector (empty
    ones of an empty vector), the initial check made by the set-up; `shared` gives every rank
    rank 0's Result, to ranks other than 0 without its fields (they hold no whole state)."""

    def __init__(self, case, problem, y0, fields, rates, chi, reason, share):
        super().__init__(case, problem, fields, rates, chi)
        self.y0, self.root, self._reason, self._share = y0, y0.size > 0, reason, share

    def initial_reason(self) -> str | None:
        return self._reason

    def shared(self, result):
        return self._share(result)


def _blocks_set_up(case, choice, settings, t_end, backend):
    """(View, rates counted, the bar's note) of the PETSc engine on the blocks of the py-pde
    scheme's grid, each rank building its own block alone (:func:`~icidr_pde.engines.petsc.block_problem`:
    its initial data, its rows of the Jacobian's pattern and values; no whole-grid Jacobian,
    pattern or rates). Rank 0 alone holds whole states: those its outputs keep (the initial
    state, the snapshots, the last states, the final state, docs/distributed.md), and the whole
    initial rates once, for the initial check's message; atol is checked against the largest
    initial field value over the ranks."""
    import dataclasses

    from .engines.petsc import _petsc, block_problem
    from .mpi_ranks import broadcast, reduce_max
    from .engines.stiff import check_memory, scheme_patches
    from .validation import invalid_state, nonfinite_rates

    PETSc = _petsc()
    comm = PETSc.COMM_WORLD
    pde, grid = case.pde, case.grid
    check_memory(pde, grid, settings["method"], choice)  # before the engine allocates
    shape = (3,) + tuple(grid.shape)
    counted = [0]
    patches = scheme_patches(pde, None, choice, None, grid=grid)
    rates_of_block = patches.rates

    def rates(g, low, high, out):  # this rank's evaluations, counted (before, only the time scale's were)
        counted[0] += 1
        rates_of_block(g, low, high, out)

    patches = dataclasses.replace(patches, rates=rates)

    def fields(y):
        return np.reshape(y, shape) if np.size(y) else np.empty((shape[0], 0, 0))

    check_state = getattr(pde, "check_state", lambda data: None)

    def check(y):
        return invalid_state(y, check_state, fields)

    solver = choice.solver
    split = solver.proc_sizes(comm.size) if getattr(solver, "shell", None) is not None else None  # the PC's split
    problem, blocks = block_problem(PETSc, patches, case.initial_block, check, comm, split)
    scale = reduce_max(float(np.max(np.abs(problem.y0))) if problem.y0.size else 0.0)
    check_atol(settings["atol"], [scale], settings["atol_asked"])
    root = comm.rank == 0
    y0 = np.array(case.initial, dtype=float).ravel() if root else np.empty(0)
    x0 = blocks.da.createGlobalVec()
    x0.setArray(problem.y0)
    f0 = x0.duplicate()
    blocks.rates(x0, f0)  # the patch kernel compiled or loaded now (set-up time), the initial rates
    blocks.jacobian_slots(x0)  # the law's Jacobian kernels and the slots' pass, as _compile_jacobian does
    whole_rates = blocks.to_root(f0)
    counted[0] = 0  # the run's evaluations (the time scale's, the integrator's), as the other engines count them
    reason = None
    if root:
        invalid = check(y0)
        with np.errstate(all="ignore"):
            reason = f"initial state invalid: {invalid}" if invalid else nonfinite_rates(fields(whole_rates), 0.0)
    reason = broadcast(reason)

    def share(result):
        if comm.size == 1:
            return result
        light = None
        if root:
            empty = np.empty((0,) + shape)
            light = dataclasses.replace(result, z=np.empty(0), phi=empty[:, 0], u=empty[:, 1], w=empty[:, 2],
                                        final=type(result.final)(*np.empty((3, 0))), last_states=empty,
                                        summary=result.to_dict())
        light = broadcast(light)
        return result if root else light

    def chi(data):
        z, phi, uz, wz = case.strain_rates(data)
        return z, case.rheology.chi(phi, uz, wz)

    view = _BlocksView(case, problem, y0, fields, lambda y: fields(np.empty(0)), chi, reason, share)
    return view, lambda: counted[0], lambda compile_s: f"compiled in {compile_s:.1f} s"


def _check_stiffness(problem, y0, t_end):
    """NativeUnavailable where the run is stiffer than the native problem's linear solver follows
    (its ``max_stiffness``: t_end over the fastest time scale), so that the run takes the py-pde
    path, whose Krylov solves are preconditioned, instead of failing as if the law did."""
    limit = getattr(problem, "max_stiffness", None)
    stiffness = 0.0 if limit is None else t_end / problem.time_scale(y0)
    if limit is not None and stiffness > limit:
        from .native import NativeUnavailable

        raise NativeUnavailable(f"t_end / fastest time scale = {stiffness:.2g} > {limit:.0e}, too stiff for its "
                                "GMRES without a preconditioner")


def _compile_jacobian(problem) -> None:
    """Call the compiled analytic Jacobian (or its x-average, 'fourier') once at y0: its first call
    compiles it (seconds on an empty cache), set-up time (compile_s) rather than the solve's (wall_s)."""
    spec, y0 = problem.jacobian, np.array(problem.y0)
    if spec.jac is not None:
        spec.jac(0.0, y0)
    elif spec.x_average is not None:
        spec.x_average(0.0, y0)
    elif spec.band_jac is not None and y0.size <= 3000:  # into a dense array: small grids only
        spec.band_jac(y0, np.zeros((y0.size, y0.size)))


def _cell_ask(discretization, scene, scene_cls, N, scene_params, request) -> dict:
    """What :func:`choose` asks of the cells of the run (:func:`~icidr_pde.cells.choice_asks`): its
    scheme's Jacobian structure and native engine, and its grid (the 2-D cell: cells and whether it
    is thin; :meth:`~icidr_pde.cells.base.Cell.choice_grid`)."""
    from .cells import cell_for, choice_asks

    cell = cell_for(scene_cls, N)
    return choice_asks(discretization, cell, request, **cell.choice_grid(scene, N, scene_params))


def _not_written(result: Result, name: str, path, why: str) -> None:
    result.not_written[name] = why
    warnings.warn(f"`{name}` {path} was not written: {why}", RuntimeWarning, stacklevel=3)
