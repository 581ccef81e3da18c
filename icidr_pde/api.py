"""One run path: validate, choose the engine, build the case, integrate, assemble the Result.

:func:`run` checks every argument once, resolves the preset once, asks
:func:`~icidr_pde.engines.choose.choose` once for the engine, Jacobian and linear solver,
builds the case (the native engine's py-pde-free one, or the py-pde scheme's), advances the
engine through the merged output times of :func:`schedule` (:func:`_drive`, the same for every
engine: the native one many outputs per call into C) and builds the Result by :func:`assemble`.
Only a run that asks for what py-pde's trackers write (a snapshot file, a movie, a live plot,
a wall-clock limit) takes py-pde's Controller with :func:`make_trackers`, :func:`integrate` and
:func:`collect` (also the failure-time study's functions). Light: a run on the native engine
imports neither py-pde, numba, scipy, sympy nor scikit-sundae.
"""

from __future__ import annotations

import sys
import time as _time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .engines.base import SimulationFailed, check_tolerances
from .engines.choose import SCHEME_STRUCTURES, Choice, JacobianStructure, choose
from .presets import resolve
from .result import Result
from .rheology import Material
from .scenes import SCENES, Scene
from .times import (check_t_end, chi_times, dense_times, merged_output_times, time_labels as _time_labels)
from .validation import check_atol, nonfinite_rates, output_path, real

__all__ = ["run", "make_pde", "DISCRETIZATIONS", "make_trackers", "integrate", "collect", "Recorders",
           "Outcome", "Schedule", "schedule"]


def __getattr__(name):  # py-pde is imported only by the runs that take it
    if name == "make_pde":
        from .case import make_pde

        return make_pde
    if name == "DISCRETIZATIONS":
        from .discretizations import DISCRETIZATIONS

        return DISCRETIZATIONS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@dataclass
class Schedule:
    """The output times of a run, for every engine: snapshot `labels` and `snap_times`, the
    max|w| series `series` and the chi samples `chi_times` (empty: none)."""

    labels: list
    snap_times: np.ndarray
    series: np.ndarray
    chi_times: np.ndarray


def schedule(scene, t_end: float, times=None, *, series_times=None, chi: bool | None = None) -> Schedule:
    """Snapshots at `times` (default: the scene's), max|w| at `series_times` (default dense;
    empty: none), chi of (A18) if the scene asks for it (or `chi`)."""
    if times is None:
        times = [t for t in scene.default_times if t <= t_end] + [t_end]
    labels, snap_times = _time_labels(times, t_end)
    series = dense_times(t_end) if series_times is None else np.sort(np.asarray(series_times, float))
    with_chi = chi or (chi is None and "chi" in scene.outputs)
    return Schedule(labels, snap_times, series, chi_times(t_end) if with_chi else np.empty(0))


@dataclass
class Recorders:
    """The trackers of a run and what they record."""

    labels: list
    snapshot_times: np.ndarray
    storage: object  # py-pde's MemoryStorage
    max_w: object  # MaxWTracker or None
    chi: object  # ChiTracker or None
    trackers: list = field(default_factory=list)
    movie: object = None  # MovieTracker or None


def make_trackers(case, t_end: float, times=None, *, series_times=None, chi: bool | None = None,
                  save: str | None = None, progress: bool = False, live_plot: bool = False,
                  max_wall: float | None = None, movie: str | None = None,
                  frame_dt: float | None = None) -> Recorders:
    """Snapshots at `times` (default: the scene's), max|w| at `series_times` (default dense;
    empty: none), chi of (A18) if the scene asks for it (or `chi`), optional HDF5 file,
    progress bar, live plot, movie frames every `frame_dt` and a wall-clock limit `max_wall`
    (seconds)."""
    from pde import MemoryStorage

    from .trackers import ChiTracker, MaxWTracker

    sched = schedule(case.scene, t_end, times, series_times=series_times, chi=chi)
    labels, snap_times = sched.labels, sched.snap_times
    storage = MemoryStorage()
    trackers = [storage.tracker(interrupts=list(snap_times))]
    max_w = MaxWTracker(interrupts=list(sched.series)) if sched.series.size else None
    if max_w is not None:
        trackers.append(max_w)
    chi_tracker = None
    if sched.chi_times.size:
        chi_tracker = ChiTracker(case.pde, interrupts=list(sched.chi_times))  # a few samples: a diagnostic
        trackers.append(chi_tracker)
    view = _view_trackers(case, t_end, progress, live_plot, movie, frame_dt)
    if save:  # last: a temporary file, created once nothing else can fail here
        from .snapshots import SnapshotFile

        snapshot_file = SnapshotFile(save, case.nodes(), list(snap_times))  # never half-written
        trackers.append(snapshot_file.tracker())
    trackers += view
    if max_wall is not None:
        trackers.append(_wall_clock_limit(max_wall, t_end))
    movie_tracker = next((t for t in view if type(t).__name__ == "MovieTracker"), None)
    return Recorders(labels, snap_times, storage, max_w, chi_tracker, trackers, movie_tracker)


def _view_trackers(case, t_end, progress, live_plot, movie, frame_dt) -> list:
    """Trackers that show a run: progress bar, live figure (with chi for mu(I)), movie frames."""
    from .trackers import LivePlotTracker, ProgressBarTracker

    title = f"{case.pde.rheology.name} {case.scene.name} {case.pde.name} N={case.N}"
    trackers = []
    if progress:
        trackers.append(ProgressBarTracker(t_end=t_end))
    if (live_plot or movie) and case.state.data.ndim > 2:
        raise ValueError("`live_plot` and `movie` draw 1-D scenes (fields against z); "
                         f"got the 2-D scene {case.scene.name!r}")
    if live_plot:
        chi = None
        if case.pde.rheology.name == "mui":  # chi (A18) is the ill-posedness test of mu(I)
            def chi(data):
                z_s, phi, uz, wz = case.pde.strain_rates(data, case.grid)
                return z_s, case.pde.rheology.chi(phi, uz, wz)
        trackers.append(LivePlotTracker(case.nodes(), t_end, chi=chi, title=title))
    if movie:  # rendered by run() after the timing
        from .movies.tracker import MovieTracker

        trackers.append(MovieTracker(movie, case.nodes(), t_end, frame_dt, title=title, write_on_finalize=False,
                                     progress=progress))
    return trackers


def _wall_clock_limit(max_wall: float, t_end: float):
    """A tracker that ends the run once it has taken `max_wall` seconds (checked at 200 times)."""
    from pde.trackers.base import FinishedSimulation
    from pde.trackers.trackers import CallbackTracker

    class _Timeout(FinishedSimulation):
        pass

    start = _time.perf_counter()

    def check(state, t):
        if _time.perf_counter() - start > max_wall:
            raise _Timeout(f"timeout after {max_wall} s wall at t = {t:.6g}")

    windows = np.geomspace(min(1e-4, t_end / 10), t_end, 200)
    return CallbackTracker(check, interrupts=list(windows))


@dataclass
class Outcome:
    """How an integration ended."""

    final: np.ndarray
    blew_up: bool
    t_star: float | None
    reason: str
    t_final: float
    wall_s: float
    compile_s: float
    cpu_s: float | None = None  # CPU time of the solve (this process), set-up excluded


def integrate(case, solver, t_end: float, trackers: list) -> Outcome:
    """Integrate `case` to `t_end` with `solver`, calling `trackers` at their interrupts.

    A failure is not an exception: the Outcome says blew_up, t* (last accepted time) and why,
    with the state at t*. wall_s excludes the kernels' set-up time (compile_s). A max|w|
    series with listed times is recorded by the solver inside its loop, not at interrupts.
    """
    from pde.solvers import Controller

    from .trackers import MaxWTracker

    check_atol(solver.atol, case.state.data)
    solver.check_memory(case.state)  # before the solver allocates its matrices
    in_loop = [t for t in trackers if isinstance(t, MaxWTracker) and t.series_times is not None]
    for tracker in in_loop:
        solver.record(tracker.series_times, tracker.record)
    controller = Controller(solver, t_range=(0.0, t_end), tracker=[t for t in trackers if t not in in_loop])
    start, cpu_start = _time.perf_counter(), _time.process_time()
    try:
        final = controller.run(case.state).data.copy()  # run() works on a copy of the state
        blew_up, t_star, t_final = False, None, t_end
        reason = "reached t_end"
        stop = controller.info.get("stop_reason", "Reached final time")
        if solver.interrupted is not None and stop == "Reached final time":  # in the last call's loop
            stop, controller.info["t_final"] = "User interrupted simulation", solver.interrupted
        if stop != "Reached final time":  # a tracker ended the run (e.g. the wall-clock limit)
            reason, t_final = stop, float(controller.info.get("t_final", t_end))
        if stop == "User interrupted simulation":  # py-pde's Controller swallows KeyboardInterrupt
            reason = f"interrupted at t = {t_final:.6g}"
    except SimulationFailed as failure:
        blew_up, t_star, reason, t_final = True, failure.t_star, failure.reason, failure.t_star
        final = failure.state_data
        info = {"controller": {"successful": False, "t_final": t_star, "stop_reason": reason, "state_data": final}}
        for tracker in trackers:  # close files and progress bars; the bar and a movie end at t*
            tracker.finalize(info=info)
    compile_s = solver.info.get("compile_s", 0.0)
    wall = _time.perf_counter() - start - compile_s
    cpu = _time.process_time() - cpu_start - solver.info.get("compile_cpu_s", 0.0)
    return Outcome(final, blew_up, t_star, reason, float(t_final), wall, compile_s, cpu)


def _plane_kwargs(case, data) -> dict:
    """Grid and per-snapshot measures of a 2-D run (nothing for the 1-D cell)."""
    if getattr(case.pde, "dim", 1) != 2:
        return {}
    from .discretizations.cartesian2d import measures

    return dict(Nx=int(case.grid.shape[0]), L=float(case.grid.axes_bounds[0][1]),
                measures=[measures(case.pde, case.grid, case.scene, d) for d in data])


@dataclass
class Recorded:
    """What a run recorded, whichever engine ran it: the snapshots done (`times`, `data`
    (n, 3, N)), the max|w| series (None: not recorded) and the chi samples (chi_t empty: none)."""

    times: np.ndarray
    data: np.ndarray
    max_w_t: list | None
    max_w: list | None
    chi_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    chi_z: np.ndarray | None = None
    chi: np.ndarray | None = None


def assemble(*, rheology: str, scene, discretization: str, N: int, z, mass, material: dict, t_end: float,
             rtol: float, atol: float, method: str, choice: Choice, accuracy, options: dict, labels: list,
             recorded: Recorded, outcome: Outcome, counts: tuple, y0_data, plane: dict | None = None) -> Result:
    """The Result of a run of any engine: what it recorded, how it ended, its counts (steps,
    RHS, Jacobians, LUs) and its settings (the options of the scheme, engine, linear solver
    and Jacobian of the choice)."""
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
        phi=data[:, 0], u=data[:, 1], w=data[:, 2], final=tuple(outcome.final),
        max_w_t=np.array(max_w_t), max_w=np.array(max_w),
        mass_drift=(mass(outcome.final) - mass0) / mass0,
        wall_s=outcome.wall_s, compile_s=outcome.compile_s, cpu_s=outcome.cpu_s, n_steps=n_steps, n_rhs=n_rhs,
        n_jac=n_jac, n_lu=n_lu, scene_params=scene.parameters(), material=material,
        settings=dict(accuracy=accuracy, **options, engine=choice.engine, linear_solver=choice.linear_solver,
                      jacobian=choice.jacobian),
        **chi_kwargs, **(plane or {}),
    )


def collect(case, settings: dict, solver, recorders: Recorders, outcome: Outcome,
            accuracy: str | None = None) -> Result:
    """The Result of a run on a py-pde case from what the trackers recorded and how it ended
    (`settings`: t_end; the solver's choice of engine, Jacobian and linear solver)."""
    storage = recorders.storage
    data = np.array(storage.data) if len(storage) else np.empty((0, *case.state.data.shape))
    n_snap = data.shape[0]
    recorded = Recorded(np.array(storage.times[:n_snap]), data, [], [])
    if recorders.max_w is None:  # no series: none appended at t* either
        recorded.max_w_t = recorded.max_w = None
    else:
        recorded.max_w_t, recorded.max_w = list(recorders.max_w.times), list(recorders.max_w.values)
    if recorders.chi is not None and recorders.chi.values:
        recorded.chi_t, recorded.chi_z = np.array(recorders.chi.times), recorders.chi.z
        recorded.chi = np.array(recorders.chi.values)
    choice = solver.choice
    if solver.info.get("linear_solver"):  # the engine's own name (a preconditioner it attached)
        choice = Choice(choice.engine, choice.jacobian, solver.info["linear_solver"], choice.reason)
    stats = solver.stats
    return assemble(rheology=case.pde.rheology.name, scene=case.scene, discretization=case.pde.name, N=case.N,
                    z=case.nodes(), mass=lambda data: case.mass(data), material=case.pde.material.to_dict(),
                    t_end=settings["t_end"], rtol=solver.rtol, atol=solver.atol, method=solver.method,
                    choice=choice, accuracy=accuracy, options=case.pde.option_values(), labels=recorders.labels,
                    recorded=recorded, outcome=outcome,
                    counts=(stats.n_steps, stats.n_rhs, stats.n_jac, stats.n_lu), y0_data=case.state.data,
                    plane=_plane_kwargs(case, data))


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
        N: number of grid cells ('fd') or collocation points with walls ('cheb'); for
            'fv2d' Nz or the pair (Nx, Nz)
        t_end: final time
        times: snapshot times (strings keep their spelling as labels)
        accuracy: preset 'draft', 'standard' or 'publication' (see :mod:`icidr_pde.presets`);
            it fills in discretization, N, method, rtol and atol where they are None
        discretization: a registered scheme: 'fd' (finite volumes on py-pde's grid) or
            'cheb' (Chebyshev)
        method: 'BDF', 'Radau', 'LSODA' (scipy) or 'CVODE' (SUNDIALS, the fast path)
        rtol, atol: integrator tolerances
        jacobian: 'analytic', 'sparse-fd', 'banded-fd' or 'none' (None: the method's default)
        material: laws and parameters (default Table 1)
        advection: 'upwind' or 'central' (an option of 'fd'; None: the scheme's default)
        progress: show a progress bar (tqdm.auto; see :class:`~icidr_pde.trackers.ProgressBarTracker`)
        live_plot: one figure of the fields updated in place while they evolve, redrawn within
            ~10 % of the wall time (:class:`~icidr_pde.trackers.LivePlotTracker`), Jupyter or a window
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
            in the loop) where it applies (fd or cheb, CVODE, analytic Jacobian, no file, movie, live
            plot or wall limit), else a Python engine on the py-pde scheme (scipy or scikit-sundae);
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
    two_d = isinstance(settings["N"], (tuple, list)) or getattr(scene_cls, "dim", 1) != 1
    outputs = [what for what, value in (("--save", save), ("--movie", movie), ("a live plot", live_plot),
                                        ("a wall-clock limit", max_wall)) if value]
    ask = dict(method=settings["method"], jacobian=jacobian, discretization=settings["discretization"],
               structure=SCHEME_STRUCTURES.get(settings["discretization"], JacobianStructure()), request=engine,
               outputs=outputs, backend=backend, dim=2 if two_d else 1)
    choice = choose(**ask)
    if choice.engine == "native":
        from .native import NativeUnavailable

        try:
            result = _run_native(rheology, scene, settings, t_end, times, choice, accuracy=accuracy,
                                 material=material, advection=advection, progress=progress,
                                 series_times=series_times, scene_params=scene_params)
        except NativeUnavailable as err:
            sys.stderr.write(f"icidr-pde: native engine not available ({err}); running the py-pde path\n")
            choice = choose(**dict(ask, native_unavailable=str(err)))
        else:
            if on_result is not None:
                on_result(result)
            return result
    elif engine == "native":
        sys.stderr.write(f"icidr-pde: native engine not used: {choice.reason}; running the py-pde path\n")
    return _run_pde(rheology, scene, settings, t_end, times, choice, accuracy=accuracy, material=material,
                    advection=advection, progress=progress, live_plot=live_plot, save=save, movie=movie,
                    frame_dt=frame_dt, series_times=series_times, backend=backend, max_wall=max_wall,
                    on_result=on_result, scene_params=scene_params)


def _run_pde(rheology, scene, settings, t_end, times, choice, *, accuracy, material, advection, progress,
             live_plot, save, movie, frame_dt, series_times, backend, max_wall, on_result, scene_params):
    """A run on the py-pde scheme with a Python engine (scipy, scikit-sundae) of `choice`."""
    from .case import build_case
    from .discretizations import get_discretization
    from .engines.stiff import StiffSolver

    options = {}
    if advection is not None:
        if "advection" not in get_discretization(settings["discretization"]).options:
            raise ValueError(f"`advection` is not an option of discretization {settings['discretization']!r}")
        options["advection"] = advection
    case = build_case(rheology, scene, settings["discretization"], settings["N"], material=material,
                      options=options, scene_params=scene_params)
    if not (save or movie or live_plot or max_wall):  # nothing for py-pde's trackers: the run path drives
        result = _run_scheme(case, settings, t_end, times, choice, accuracy=accuracy, progress=progress,
                             series_times=series_times, backend=backend)
        if on_result is not None:
            on_result(result)
        return result
    solver = StiffSolver(case.pde, method=settings["method"], rtol=settings["rtol"], atol=settings["atol"],
                         jacobian=choice.jacobian, backend=backend, choice=choice)
    recorders = make_trackers(case, t_end, times, series_times=series_times, save=save, progress=progress,
                              live_plot=live_plot, max_wall=max_wall, movie=movie, frame_dt=frame_dt)
    snapshot_file = next((t.snapshot_file for t in recorders.trackers if hasattr(t, "snapshot_file")), None)
    try:
        outcome = integrate(case, solver, t_end, recorders.trackers)
    finally:  # a run that raised leaves an existing snapshot file as it was
        if snapshot_file is not None:
            snapshot_file.discard()
    result = collect(case, dict(settings, t_end=t_end), solver, recorders, outcome, accuracy)
    if snapshot_file is not None and snapshot_file.error is not None:
        _not_written(result, "save", save, snapshot_file.error)
    if on_result is not None:
        on_result(result)
    if recorders.movie is not None:  # after the timing: wall_s is the solve and the trackers
        try:
            recorders.movie.write()
        except KeyboardInterrupt:  # the run's results stay; the movie is left as it was
            _not_written(result, "movie", movie, "interrupted")
        except OSError as err:
            _not_written(result, "movie", movie, err.strerror or str(err))
    return result


#: output times per call into C, adapted to take 0.02-0.1 s a call: Ctrl-C and the progress bar
#: act between calls, and a call costs ~1 us of Python
_CHUNK = (8, 1, 1024)  # first, smallest, largest


def _native_case(rheology, scene, settings, *, material, advection, scene_params):
    """The py-pde-free case of the native engine's scheme (:mod:`icidr_pde.native`)."""
    if settings["discretization"] == "cheb":
        from .native.cheb import ChebCase as case_class
    else:
        from .native import FdCase as case_class
    return case_class(rheology, scene, settings["N"], material=material, advection=advection,
                      scene_params=scene_params)


@dataclass
class _Outputs:
    """The schedule of a native run as output indices: merged times, where each list's times
    are, which outputs keep their state (store[k] >= 0) and the arrays CVODE writes."""

    times: np.ndarray
    at_series: np.ndarray
    at_snap: np.ndarray
    at_chi: np.ndarray
    store: np.ndarray
    states: np.ndarray
    max_w: np.ndarray

    @classmethod
    def of(cls, sched: Schedule, t_end: float, n: int) -> "_Outputs":
        times, (at_series, at_snap, at_chi) = merged_output_times(t_end, [sched.series, sched.snap_times,
                                                                          sched.chi_times])
        stored = np.unique(np.concatenate([at_snap, at_chi, [times.size - 1]]).astype(int))
        stored = stored[stored >= 0]
        store = np.full(times.size, -1, dtype=np.intc)
        store[stored] = np.arange(stored.size)
        return cls(times, at_series, at_snap, at_chi, store, np.empty((max(stored.size, 1), n)),
                   np.full(times.size, np.nan))


def _advance(engine, out: _Outputs, bar, measure):
    """Advance the engine through every output, chunk by chunk (the native engine: no Python
    per step). Returns (outputs done, failure or None); a KeyboardInterrupt ends it where the
    engine stopped."""
    n_done, n_out, failure = 0, out.times.size, None
    size, smallest, largest = _CHUNK
    try:
        while n_done < n_out and failure is None:
            chunk = slice(n_done, min(n_done + size, n_out))
            call = _time.perf_counter()
            done, failure = engine.advance_outputs(out.times[chunk], out.store[chunk], out.max_w[n_done:], out.states,
                                                   measure)
            call = _time.perf_counter() - call
            size = min(2 * size, largest) if call < 0.02 else max(size // 2, smallest) if call > 0.1 else size
            n_done += done
            if bar is not None and n_done:
                bar.advance(out.times[n_done - 1])
    except KeyboardInterrupt:
        n_done = _outputs_reached(engine, out, n_done)
    return n_done, failure


def _outputs_reached(engine, out: _Outputs, n_done: int) -> int:
    """Outputs done when Ctrl-C came: the signal is seen only once the engine has returned,
    possibly before Python counted the outputs of that call (written, and the last kept)."""
    reached = int(np.searchsorted(out.times, engine.last_good()[0], side="right"))
    while reached > n_done and not np.isfinite(out.max_w[reached - 1]):  # stopped on an invalid state
        reached -= 1
    return max(n_done, reached)


class _NativeView:
    """The run path's view of a native case and its compiled problem."""

    def __init__(self, case, problem):
        self.case, self.problem = case, problem
        self.scene, self.N, self.z, self.y0 = case.scene, case.N, case.z, case.y0
        self.fields, self.mass = case.fields, case.mass

    def initial_reason(self) -> str | None:
        invalid = self.case.check_state(self.y0)
        if invalid:
            return f"initial state invalid: {invalid}"
        return nonfinite_rates(self.fields(self.problem.rates(self.y0)))

    def chi(self, data):
        from .rheology.base import chi_of_M

        z_f, phi_f, uz, wz = self.case.strain_rates(data)
        return z_f, chi_of_M(self.problem.M(phi_f), uz, wz)


class _SchemeView:
    """The run path's view of a py-pde case on a Python engine, in the engine's ordering."""

    def __init__(self, case, problem, ordering):
        self.case, self.problem, self.ordering = case, problem, ordering
        self.scene, self.N, self.z, self.y0 = case.scene, case.N, case.nodes(), problem.y0
        self.fields, self.mass = ordering.to_native, case.mass

    def initial_reason(self) -> str | None:
        invalid = self.problem.check(self.y0)
        if invalid:
            return f"initial state invalid: {invalid}"
        with np.errstate(all="ignore"):
            return nonfinite_rates(self.ordering.rhs(self.fields(self.y0), 0.0), 0.0)

    def chi(self, data):
        pde = self.case.pde
        z, phi, uz, wz = pde.strain_rates(data, self.case.grid)
        return z, pde.rheology.chi(phi, uz, wz)

    def max_abs_w(self, y) -> float:
        return float(np.max(np.abs(self.fields(y)[2])))


def _drive(view, make_engine, sched: Schedule, t_end: float, bar):
    """Integrate from the view's y0 through the schedule: (outputs, outputs done, failure, engine)."""
    out, y0 = _Outputs.of(sched, t_end, view.y0.size), view.y0
    engine, n_done, failure = None, 0, None
    try:
        reason0 = view.initial_reason()
        if reason0:
            failure = (0.0, y0.copy(), reason0)
        else:
            engine = make_engine()
            n_done, failure = _advance(engine, out, bar, getattr(view, "max_abs_w", None))
    except KeyboardInterrupt:  # before the engine started: nothing computed past t = 0
        engine = None
    finally:
        if bar is not None:
            _close_bar(bar, failure, n_done < out.times.size, engine, t_end)
    return out, n_done, failure, engine


def _run_native(rheology, scene, settings, t_end, times, choice, *, accuracy, material, advection, progress,
                series_times, scene_params) -> Result:
    """A run on the native engine (:mod:`icidr_pde.engines.native`); raises NativeUnavailable
    (before any work) where its library cannot be built."""
    from .engines.native import NativeEngine

    case = _native_case(rheology, scene, settings, material=material, advection=advection,
                        scene_params=scene_params)
    check_atol(settings["atol"], case.y0)
    sched = schedule(case.scene, t_end, times, series_times=series_times)
    start = _time.perf_counter()
    problem = case.problem()
    compile_s = _time.perf_counter() - start
    start, cpu_start = _time.perf_counter(), _time.process_time()
    bar = None
    if progress:
        from .progress import TimeBar

        # refreshed every 0.1 s also into a pipe, as tqdm does by default: a reader sees the time move
        bar = TimeBar(t_end, "integrating", f"native, ready in {compile_s:.2g} s", log_interval=0.1)
    view = _NativeView(case, problem)

    def make_engine():
        return NativeEngine("CVODE", problem, 0.0, case.y0, rtol=settings["rtol"], atol=settings["atol"],
                            check=case.check_state, linear_solver=choice.linear_solver)

    out, n_done, failure, engine = _drive(view, make_engine, sched, t_end, bar)
    wall, cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    outcome = _outcome(view, engine, out, n_done, failure, t_end, wall, compile_s, cpu)
    counts = problem.counts()
    if engine is not None:  # the linear solver the compiled problem set up
        choice = Choice(choice.engine, choice.jacobian, engine.linear_solver, choice.reason)
    return assemble(rheology=case.rheology.name, scene=case.scene, discretization=case.discretization, N=case.N,
                    z=case.z, mass=case.mass, material=case.rheology.material.to_dict(), t_end=t_end,
                    rtol=settings["rtol"], atol=settings["atol"], method="CVODE", choice=choice, accuracy=accuracy,
                    options={"advection": case.advection} if case.advection else {}, labels=sched.labels,
                    recorded=_recorded(view, sched, out, n_done), outcome=outcome,
                    counts=(counts["steps"], counts["rhs"], counts["jac"], counts["lu"]),
                    y0_data=case.fields(case.y0))


def _run_scheme(case, settings, t_end, times, choice, *, accuracy, progress, series_times, backend) -> Result:
    """A run of a py-pde case on a Python engine (scipy, scikit-sundae) driven by the run path:
    the engine advanced to each output time of the schedule, no py-pde Controller or tracker."""
    from .engines import engine_class
    from .engines.base import StepStatistics
    from .engines.stiff import StiffSolver, check_memory, scheme_problem

    check_atol(settings["atol"], case.state.data)
    check_memory(case.pde, case.state, settings["method"], choice)  # before anything is allocated
    sched = schedule(case.scene, t_end, times, series_times=series_times)
    bar = None
    if progress:
        from .progress import TimeBar

        bar = TimeBar(t_end, "compiling", log_interval=0.1)
    start, cpu_start = _time.perf_counter(), _time.process_time()
    stats = StepStatistics()
    rhs = StiffSolver(case.pde, method=settings["method"], rtol=settings["rtol"], atol=settings["atol"],
                      backend=backend, choice=choice)._rates(case.state)
    rhs(np.array(case.state.data), 0.0)  # compile or load now, so that it counts as set-up time
    problem, ordering = scheme_problem(case.pde, case.state, choice, rhs, stats)
    compile_s, compile_cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    if bar is not None:
        bar.integrating(f"compiled in {compile_s:.1f} s")
    view = _SchemeView(case, problem, ordering)

    def make_engine():
        return engine_class(choice.engine)(settings["method"], problem, 0.0, rtol=settings["rtol"],
                                           atol=settings["atol"], linear_solver=choice.linear_solver)

    out, n_done, failure, engine = _drive(view, make_engine, sched, t_end, bar)
    wall = _time.perf_counter() - start - compile_s
    cpu = _time.process_time() - cpu_start - compile_cpu
    outcome = _outcome(view, engine, out, n_done, failure, t_end, wall, compile_s, cpu)
    if engine is not None:
        stats.n_steps, stats.n_jac, stats.n_lu = engine.counts()
        choice = Choice(choice.engine, choice.jacobian, engine.linear_solver, choice.reason)
    recorded = _recorded(view, sched, out, n_done)
    return assemble(rheology=case.pde.rheology.name, scene=case.scene, discretization=case.pde.name, N=case.N,
                    z=view.z, mass=case.mass, material=case.pde.material.to_dict(), t_end=t_end,
                    rtol=settings["rtol"], atol=settings["atol"], method=settings["method"], choice=choice,
                    accuracy=accuracy, options=case.pde.option_values(), labels=sched.labels, recorded=recorded,
                    outcome=outcome, counts=(stats.n_steps, stats.n_rhs, stats.n_jac, stats.n_lu),
                    y0_data=case.state.data, plane=_plane_kwargs(case, recorded.data))


def _close_bar(bar, failure, interrupted, engine, t_end):
    if failure is not None:
        bar.close(failure[0], "failed", failure[2])
    elif interrupted:
        bar.close(engine.last_good()[0] if engine is not None else 0.0, "interrupted")
    else:
        bar.close(t_end)


def _outcome(view, engine, out: _Outputs, n_done, failure, t_end, wall, compile_s, cpu) -> Outcome:
    if failure is not None:
        t_final, final = failure[0], view.fields(failure[1])
        return Outcome(final, True, float(t_final), failure[2], float(t_final), wall, compile_s, cpu)
    if n_done < out.times.size:  # interrupted: the last output state the engine returned
        t_final, y_last = engine.last_good() if engine is not None else (0.0, view.y0)
        return Outcome(view.fields(y_last), False, None, f"interrupted at t = {t_final:.6g}", float(t_final),
                       wall, compile_s, cpu)
    final = view.fields(out.states[out.store[-1]])
    return Outcome(final, False, None, "reached t_end", float(t_end), wall, compile_s, cpu)


def _recorded(view, sched: Schedule, out: _Outputs, n_done: int) -> Recorded:
    """Snapshots, series and chi of the outputs a run reached."""
    y0, fields = view.y0, view.fields

    def state_at(index):
        return y0 if index < 0 else out.states[out.store[index]]

    # one snapshot per distinct time, labelled by the first labels (as py-pde's storage records them)
    snap = sched.snap_times
    snaps = [k for k, i in enumerate(out.at_snap) if i < n_done and (k == 0 or snap[k] > snap[k - 1])]
    shape = fields(y0).shape
    data = np.array([fields(state_at(out.at_snap[k])) for k in snaps]).reshape(len(snaps), *shape)
    recorded = Recorded(snap[snaps], data, None, None)
    if sched.series.size:
        done = [k for k, i in enumerate(out.at_series) if i < n_done]
        recorded.max_w_t = [float(out.times[out.at_series[k]]) if out.at_series[k] >= 0 else float(sched.series[k])
                            for k in done]
        recorded.max_w = [float(out.max_w[out.at_series[k]]) if out.at_series[k] >= 0
                          else float(np.max(np.abs(fields(y0)[2]))) for k in done]
    chi_done = [k for k, i in enumerate(out.at_chi) if i < n_done]
    if chi_done:
        values = []
        for k in chi_done:
            with np.errstate(all="ignore"):  # a state overflowing the strain rates has chi = inf or nan
                z_f, chi = view.chi(fields(state_at(out.at_chi[k])))
                values.append(chi)
        recorded.chi_t, recorded.chi_z = np.array([float(sched.chi_times[k]) for k in chi_done]), z_f
        recorded.chi = np.array(values)
    return recorded


def _not_written(result: Result, name: str, path, why: str) -> None:
    result.not_written[name] = why
    warnings.warn(f"`{name}` {path} was not written: {why}", RuntimeWarning, stacklevel=3)
