"""One run path: build the case, attach the trackers, integrate, collect a Result.

:func:`run` is :func:`~icidr_pde.case.build_case`, :func:`make_trackers`,
:func:`integrate` and :func:`collect`; the failure-time study and the benchmarks use
the same functions.
"""

from __future__ import annotations

import time as _time
import warnings
from dataclasses import dataclass, field

import numpy as np
from pde import MemoryStorage
from pde.solvers import Controller
from pde.trackers.base import FinishedSimulation
from pde.trackers.trackers import CallbackTracker

from .case import Case, build_case, make_pde
from .discretizations import DISCRETIZATIONS, get_discretization
from .integrator import SimulationFailed, StiffSolver
from .movies.tracker import MovieTracker
from .presets import resolve
from .result import Result
from .rheology import Material
from .scenes import SCENES, Scene
from .snapshots import SnapshotFile
from .times import check_t_end, dense_times, time_labels as _time_labels
from .trackers import ChiTracker, LivePlotTracker, MaxWTracker, ProgressBarTracker
from .validation import check_atol, output_path, real

__all__ = ["run", "make_pde", "DISCRETIZATIONS", "make_trackers", "integrate", "collect", "Recorders",
           "Outcome"]


@dataclass
class Recorders:
    """The trackers of a run and what they record."""

    labels: list
    snapshot_times: np.ndarray
    storage: MemoryStorage
    max_w: MaxWTracker | None
    chi: ChiTracker | None
    trackers: list = field(default_factory=list)
    movie: MovieTracker | None = None


def make_trackers(case: Case, t_end: float, times=None, *, series_times=None, chi: bool | None = None,
                  save: str | None = None, progress: bool = False, live_plot: bool = False,
                  max_wall: float | None = None, movie: str | None = None,
                  frame_dt: float | None = None) -> Recorders:
    """Snapshots at `times` (default: the scene's), max|w| at `series_times` (default dense;
    empty: none), chi of (A18) if the scene asks for it (or `chi`), optional HDF5 file,
    progress bar, live plot, movie frames every `frame_dt` and a wall-clock limit `max_wall`
    (seconds)."""
    if times is None:
        times = [t for t in case.scene.default_times if t <= t_end] + [t_end]
    labels, snap_times = _time_labels(times, t_end)
    storage = MemoryStorage()
    trackers = [storage.tracker(interrupts=list(snap_times))]
    series = dense_times(t_end) if series_times is None else np.asarray(series_times, float)
    max_w = MaxWTracker(interrupts=list(series)) if series.size else None
    if max_w is not None:
        trackers.append(max_w)
    chi_tracker = None
    if chi or (chi is None and "chi" in case.scene.outputs):
        chi_times = np.unique(np.concatenate(([0.0], np.geomspace(min(1e-3, t_end / 10), t_end, 20))))
        chi_tracker = ChiTracker(case.pde, interrupts=list(chi_times))  # a few samples: a diagnostic
        trackers.append(chi_tracker)
    view = _view_trackers(case, t_end, progress, live_plot, movie, frame_dt)
    if save:  # last: a temporary file, created once nothing else can fail here
        snapshot_file = SnapshotFile(save, case.nodes(), list(snap_times))  # never half-written
        trackers.append(snapshot_file.tracker())
    trackers += view
    if max_wall is not None:
        trackers.append(_wall_clock_limit(max_wall, t_end))
    movie_tracker = next((t for t in view if isinstance(t, MovieTracker)), None)
    return Recorders(labels, snap_times, storage, max_w, chi_tracker, trackers, movie_tracker)


def _view_trackers(case: Case, t_end, progress, live_plot, movie, frame_dt) -> list:
    """Trackers that show a run: progress bar, live figure (with chi for mu(I)), movie frames."""
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
        trackers.append(MovieTracker(movie, case.nodes(), t_end, frame_dt, title=title, write_on_finalize=False,
                                     progress=progress))
    return trackers


class _Timeout(FinishedSimulation):
    pass


def _wall_clock_limit(max_wall: float, t_end: float) -> CallbackTracker:
    """A tracker that ends the run once it has taken `max_wall` seconds (checked at 200 times)."""
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


def integrate(case: Case, solver: StiffSolver, t_end: float, trackers: list) -> Outcome:
    """Integrate `case` to `t_end` with `solver`, calling `trackers` at their interrupts.

    A failure is not an exception: the Outcome says blew_up, t* (last accepted time) and why,
    with the state at t*. wall_s excludes the kernels' set-up time (compile_s). A max|w|
    series with listed times is recorded by the solver inside its loop, not at interrupts.
    """
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


def _plane_kwargs(case: Case, data) -> dict:
    """Grid and per-snapshot measures of a 2-D run (nothing for the 1-D cell)."""
    if getattr(case.pde, "dim", 1) != 2:
        return {}
    from .discretizations.cartesian2d import measures

    return dict(Nx=int(case.grid.shape[0]), L=float(case.grid.axes_bounds[0][1]),
                measures=[measures(case.pde, case.grid, case.scene, d) for d in data])


def collect(case: Case, settings: dict, solver: StiffSolver, recorders: Recorders, outcome: Outcome,
            accuracy: str | None = None) -> Result:
    """The Result of a run from what the trackers recorded and how it ended."""
    z = case.nodes()
    storage = recorders.storage
    data = np.array(storage.data) if len(storage) else np.empty((0, *case.state.data.shape))
    n_snap = data.shape[0]
    max_w_t, max_w = [], []
    if recorders.max_w is not None:
        max_w_t, max_w = list(recorders.max_w.times), list(recorders.max_w.values)
        if outcome.blew_up:
            max_w_t.append(outcome.t_star)
            max_w.append(float(np.max(np.abs(outcome.final[2]))))
    chi_kwargs = {}
    if recorders.chi is not None and recorders.chi.values:
        chi_kwargs = dict(chi_t=np.array(recorders.chi.times), chi_z=recorders.chi.z,
                          chi=np.array(recorders.chi.values))
    stats = solver.stats
    mass0 = case.mass()
    return Result(
        rheology=case.pde.rheology.name, scene=case.scene.name, discretization=case.pde.name,
        N=case.N, t_end=float(settings["t_end"]), rtol=solver.rtol, atol=solver.atol,
        method=solver.method, jacobian=solver.jacobian, blew_up=outcome.blew_up, t_star=outcome.t_star,
        reason=outcome.reason, t_final=outcome.t_final, z=z, times=np.array(storage.times[:n_snap]),
        time_labels=recorders.labels[:n_snap], requested_times=recorders.labels,
        phi=data[:, 0], u=data[:, 1], w=data[:, 2], final=tuple(outcome.final),
        max_w_t=np.array(max_w_t), max_w=np.array(max_w),
        mass_drift=(case.mass(outcome.final) - mass0) / mass0,
        wall_s=outcome.wall_s, compile_s=outcome.compile_s, cpu_s=outcome.cpu_s, n_steps=stats.n_steps, n_rhs=stats.n_rhs,
        n_jac=stats.n_jac, n_lu=stats.n_lu, scene_params=case.scene.parameters(),
        material=case.pde.material.to_dict(),
        settings=dict(accuracy=accuracy, **case.pde.option_values()),
        **chi_kwargs, **_plane_kwargs(case, data[:n_snap]),
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
            take the native engine (:mod:`icidr_pde.native`: C kernels and CVODE, no Python in the
            loop) where it applies (fd or cheb, CVODE, analytic Jacobian, no file, movie, live plot
            or wall limit), else this path; 'native' says on stderr why it fell back; 'pde' is always
            this path (the one the regression anchors are pinned on). Both return the same Result
            fields; CVODE's step choices may differ by round-off (docs/engines.md)
        on_result: called with the Result once the run has ended and before the movie is
            rendered (the CLI writes --json and --plot there: an interrupt while the movie is
            rendered loses neither)

    Outputs (`save`, `movie`) are written whole or not at all (:mod:`icidr_pde.outputs`); one
    that cannot be written (a full disk, an interrupt while the movie is rendered) does not
    stop the run: the Result's `not_written` says which and why (with a RuntimeWarning).

    A failed run (step-size underflow, non-finite state, phi leaving its inertial range) is
    not an exception: the Result has blew_up=True, t_star, reason, and all that was recorded.
    """
    # every argument is checked before any work and before any output file is touched
    t_end = check_t_end(t_end)
    save, movie = output_path("save", save), output_path("movie", movie)
    frame_dt = None if frame_dt is None else real("frame_dt", frame_dt, 0)
    if engine != "pde":
        from .native import try_native

        result = try_native(engine, rheology, scene, N, t_end, times, accuracy=accuracy,
                            discretization=discretization, method=method, rtol=rtol, atol=atol,
                            jacobian=jacobian, material=material, advection=advection, progress=progress,
                            series_times=series_times, save=save, movie=movie, live_plot=live_plot,
                            max_wall=max_wall, backend=backend, **scene_params)
        if result is not None:
            return result
    if discretization is None:  # a scene of the 2-D cell names its scheme
        discretization = getattr(scene if isinstance(scene, Scene) else SCENES.get(scene), "discretization", None)
    settings = resolve(accuracy, discretization=discretization, N=N, method=method, rtol=rtol, atol=atol)
    options = {}
    if advection is not None:
        if "advection" not in get_discretization(settings["discretization"]).options:
            raise ValueError(f"`advection` is not an option of discretization {settings['discretization']!r}")
        options["advection"] = advection
    case = build_case(rheology, scene, settings["discretization"], settings["N"], material=material,
                      options=options, scene_params=scene_params)
    solver = StiffSolver(case.pde, method=settings["method"], rtol=settings["rtol"], atol=settings["atol"],
                         jacobian=jacobian, backend=backend)
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


def _not_written(result: Result, name: str, path, why: str) -> None:
    result.not_written[name] = why
    warnings.warn(f"`{name}` {path} was not written: {why}", RuntimeWarning, stacklevel=3)
