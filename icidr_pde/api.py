"""One run path: validate, choose the engine, build the case, integrate, assemble the Result.

:func:`run` checks every argument once, resolves the preset once, asks
:func:`~icidr_pde.engines.choose.choose` once for the engine, Jacobian and linear solver,
builds the case (the native engine's py-pde-free one, or the py-pde scheme's), advances the
engine through the merged output times of :func:`schedule` (:func:`_drive`, the same for every
engine: the native one many outputs per call into C) and builds the Result by :func:`assemble`.
What a run writes or shows besides the Result (a snapshot file, movie frames, a live plot) and
a wall-clock limit are recorders (:func:`make_recorders`) that :func:`_drive` calls at their
output times, merged into the schedule. Light: a run on the native engine
imports neither py-pde, numba, scipy, sympy nor scikit-sundae.
"""

from __future__ import annotations

import sys
import time as _time
import warnings
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from .engines.base import check_tolerances
from .engines.choose import SCHEME_STRUCTURES, Choice, JacobianStructure, choose
from .presets import resolve
from .result import Fields, Result
from .rheology import Material
from .scenes import SCENES, Scene, get_scene
from .times import (check_t_end, chi_times, dense_times, merged_output_times, time_labels as _time_labels)
from .validation import check_atol, nonfinite_rates, output_path, real

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


class StopRun(Exception):
    """Raised by a recorder to end a run early (a wall-clock limit): the run ends at the
    output being recorded, with this reason, not as a failure."""


class WallClock:
    """A recorder that ends the run once it has taken `max_wall` seconds (checked at 200 times)."""

    def __init__(self, max_wall: float, t_end: float):
        self.max_wall = max_wall
        self.output_times = np.geomspace(min(1e-4, t_end / 10), t_end, 200)
        self.start = _time.perf_counter()

    def record(self, t: float, data) -> None:
        if _time.perf_counter() - self.start > self.max_wall:
            raise StopRun(f"timeout after {self.max_wall} s wall at t = {t:.6g}")

    def close(self, outcome) -> None:
        pass

    def abandon(self) -> None:
        pass


def make_recorders(case, t_end: float, *, snap_times, save=None, live_plot=False, movie=None, frame_dt=None,
                   progress=False, max_wall=None) -> list:
    """The recorders of a run, called by :func:`_drive` at their `output_times` with the state
    (fields first), then closed with the Outcome: the live figure (with chi (A18) for mu(I)),
    the movie frames, the snapshot file (last: a temporary file, created once nothing else
    can fail) and the wall-clock limit (last at each time: what the others recorded stays)."""
    recorders = []
    title = f"{case.pde.rheology.name} {case.scene.name} {case.pde.name} N={case.N}"
    if (live_plot or movie) and case.state.data.ndim > 2:
        raise ValueError("`live_plot` and `movie` draw 1-D scenes (fields against z); "
                         f"got the 2-D scene {case.scene.name!r}")
    if live_plot:
        from .live_plot import LivePlot

        chi = partial(_scheme_chi, case) if case.pde.rheology.name == "mui" else None  # (A18): mu(I) ill-posed
        recorders.append(LivePlot(case.nodes(), t_end, chi=chi, title=title))
    if movie:  # rendered by run() after the timing
        from .movies.frames import MovieFrames

        recorders.append(MovieFrames(movie, case.nodes(), t_end, frame_dt, title=title, progress=progress))
    if save:
        from .snapshots import SnapshotFile

        recorders.append(SnapshotFile(save, case.nodes(), snap_times, case.state))  # never half-written
    if max_wall is not None:
        recorders.append(WallClock(max_wall, t_end))
    return recorders


def _plane_kwargs(case, data) -> dict:
    """Grid and per-snapshot measures of a 2-D run (nothing for the 1-D cell)."""
    if getattr(case.pde, "dim", 1) != 2:
        return {}
    from .cells.plane2d.pde import measures

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
    last_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    last_states: np.ndarray | None = None


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
        max_w_t=np.array(max_w_t), max_w=np.array(max_w),
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
    settings["atol_asked"] = atol is not None
    two_d = isinstance(settings["N"], (tuple, list)) or getattr(scene_cls, "dim", 1) != 1
    outputs = [what for what, value in (("--save", save), ("--movie", movie), ("a live plot", live_plot),
                                        ("a wall-clock limit", max_wall)) if value]
    ask = dict(method=settings["method"], jacobian=jacobian, discretization=settings["discretization"],
               structure=SCHEME_STRUCTURES.get(settings["discretization"], JacobianStructure()), request=engine,
               outputs=outputs, backend=backend, dim=2 if two_d else 1, max_order=max_order,
               **(_plane_grid(scene, settings["N"], scene_params) if two_d else {}))
    choice = choose(**ask)
    if choice.warning:
        sys.stderr.write(f"icidr-pde: warning: {choice.warning}\n")
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
    options = {}
    if advection is not None:
        if "advection" not in get_discretization(settings["discretization"]).options:
            raise ValueError(f"`advection` is not an option of discretization {settings['discretization']!r}")
        options["advection"] = advection
    from .engines.stiff import check_memory

    case = build_case(rheology, scene, settings["discretization"], settings["N"], material=material,
                      options=options, scene_params=scene_params,
                      check_grid=lambda pde, grid: check_memory(pde, grid, settings["method"], choice))
    outputs = dict(save=save, live_plot=live_plot, movie=movie, frame_dt=frame_dt, max_wall=max_wall)
    result, recorders = _run_scheme(case, settings, t_end, times, choice, accuracy=accuracy, progress=progress,
                                    series_times=series_times, backend=backend, outputs=outputs)
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


def _plane_grid(scene, N, scene_params) -> dict:
    """What :func:`choose` asks of the 2-D grid of `scene` with `N`: its cells and whether it is a
    thin cell (hx > THIN_CELL hz); nothing where the scene or N is invalid (the case builder says why)."""
    from .cells.plane2d.core import grid_shape, thin_cell

    try:
        scene_obj = scene if isinstance(scene, Scene) else get_scene(scene, **(scene_params or {}))
        Nx, Nz, L = grid_shape(N, scene_obj.H, L=getattr(scene_obj, "L", None))
    except (ValueError, TypeError):
        return {}
    return dict(cells=Nx * Nz, thin_cell=thin_cell(Nx, Nz, L, scene_obj.H))


#: output times per call into C, adapted to take 0.02-0.1 s a call: Ctrl-C and the progress bar
#: act between calls, and a call costs ~1 us of Python
_CHUNK = (8, 1, 1024)  # first, smallest, largest

#: states kept at the last max|w| series times before the end of a run (Result.last_states)
LAST_STATES = 6


def _native_case(rheology, scene, settings, *, material, advection, scene_params):
    """The py-pde-free case of the native engine's scheme (:mod:`icidr_pde.native`)."""
    if settings["discretization"] == "cheb":
        from .cells.shear1d.native_cheb import ChebCase as case_class
    elif settings["discretization"] == "fv2d":
        from .cells.plane2d.native import Plane2DCase as case_class
    else:
        from .cells.shear1d.native import FdCase as case_class
    return case_class(rheology, scene, settings["N"], material=material, advection=advection,
                      scene_params=scene_params)


@dataclass
class _Outputs:
    """The schedule of a run as output indices: merged times, where each list's times are
    (`at_recorders`: one array per recorder), which outputs keep their state (store[k] >= 0:
    the snapshots, chi samples and the last for the whole run, a recorder's only until it has
    been called, in a ring of slots) and the arrays the engine writes."""

    times: np.ndarray
    at_series: np.ndarray
    at_snap: np.ndarray
    at_chi: np.ndarray
    store: np.ndarray
    states: np.ndarray
    max_w: np.ndarray
    at_recorders: list = field(default_factory=list)
    at_last: np.ndarray = field(default_factory=lambda: np.empty(0, int))

    @classmethod
    def of(cls, sched: Schedule, t_end: float, n: int, recorders=()) -> "_Outputs":
        lists = [sched.series, sched.snap_times, sched.chi_times] + [r.output_times for r in recorders]
        times, (at_series, at_snap, at_chi, *at_recorders) = merged_output_times(t_end, lists)
        kept = np.unique(np.concatenate([at_snap, at_chi, [times.size - 1]]).astype(int))
        kept = kept[kept >= 0]
        store = np.full(times.size, -1, dtype=np.intc)
        store[kept] = np.arange(kept.size)
        passing = np.unique(np.concatenate([np.asarray(at, int) for at in at_recorders] or [np.empty(0, int)]))
        passing = np.setdiff1d(passing[passing >= 0], kept)
        ring = min(_CHUNK[2], passing.size)  # a chunk holds at most _CHUNK[2] consecutive outputs
        if ring:
            store[passing] = kept.size + np.arange(passing.size) % ring
        # the series' other states cycle through LAST_STATES slots: the last ones before the
        # end (a failure's t*) stay, to be drawn (only read once the run has ended)
        at_last = np.setdiff1d(np.unique(np.asarray(at_series, int)), np.concatenate([kept, passing]))
        at_last = at_last[at_last >= 0]
        last = min(LAST_STATES, at_last.size)
        if last:
            store[at_last] = kept.size + ring + np.arange(at_last.size) % last
        return cls(times, at_series, at_snap, at_chi, store, np.empty((max(kept.size + ring + last, 1), n)),
                   np.full(times.size, np.nan), at_recorders, at_last)


class _Recording:
    """Calls the recorders at their outputs in time order (at one output, in the order given),
    with the fields of the state there; a recorder's StopRun ends the run at that output."""

    def __init__(self, recorders, out: _Outputs, view):
        self.recorders, self.out, self.view = list(recorders), out, view
        events = sorted((int(i), order) for order, at in enumerate(out.at_recorders) for i in np.unique(at))
        self.events, self.next = events, 0
        self.stop: tuple[int, str, float] | None = None  # (output index, reason, time)

    def through(self, n_done: int) -> int:
        """Record every output before `n_done`; returns the outputs the run keeps (fewer on a stop)."""
        out, fields = self.out, self.view.fields
        while self.next < len(self.events) and self.events[self.next][0] < n_done and self.stop is None:
            index, order = self.events[self.next]
            self.next += 1  # first: a Ctrl-C inside a recorder does not call it twice
            y = self.view.y0 if index < 0 else out.states[out.store[index]]
            t = 0.0 if index < 0 else float(out.times[index])
            try:
                self.recorders[order].record(t, fields(y))
            except StopRun as stop:
                self.stop = (index, str(stop), t)
        return n_done if self.stop is None else self.stop[0] + 1

    def close(self, outcome) -> None:
        for recorder in self.recorders:
            recorder.close(outcome)

    def abandon(self) -> None:
        for recorder in self.recorders:
            recorder.abandon()


def _advance(engine, out: _Outputs, bar, measure, recording: _Recording):
    """Advance the engine through every output, chunk by chunk (the native engine: no Python
    per step), calling the recorders after each chunk. Returns (outputs done, failure or None);
    a KeyboardInterrupt ends it where the engine stopped, a recorder's StopRun at its output."""
    n_done, n_out, failure = 0, out.times.size, None
    size, smallest, largest = _CHUNK
    try:
        while n_done < n_out and failure is None and recording.stop is None:
            chunk = slice(n_done, min(n_done + size, n_out))
            call = _time.perf_counter()
            done, failure = engine.advance_outputs(out.times[chunk], out.store[chunk], out.max_w[n_done:], out.states,
                                                   measure)
            call = _time.perf_counter() - call
            size = min(2 * size, largest) if call < 0.02 else max(size // 2, smallest) if call > 0.1 else size
            n_done = recording.through(n_done + done)
            if bar is not None and n_done:
                bar.advance(out.times[n_done - 1])
    except KeyboardInterrupt:
        n_done = _outputs_reached(engine, out, n_done)
        try:
            n_done = recording.through(n_done)
        except KeyboardInterrupt:  # a second Ctrl-C: the recorders keep what they have
            pass
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


def _scheme_chi(case, data):
    """(positions, chi of (A18)) of the state `data` of a py-pde case."""
    z, phi, uz, wz = case.pde.strain_rates(data, case.grid)
    return z, case.pde.rheology.chi(phi, uz, wz)


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
        return _scheme_chi(self.case, data)

    def max_abs_w(self, y) -> float:
        return float(np.max(np.abs(self.fields(y)[2])))


def _drive(view, make_engine, sched: Schedule, t_end: float, bar, recorders=()):
    """Integrate from the view's y0 through the schedule and the recorders' output times,
    calling the recorders there: (outputs, outputs done, failure, engine, recording), where
    recording.stop is None or (output index, reason, time) of a recorder that ended the run. The recorders are
    abandoned if this raises (a snapshot file leaves the target as it was); the caller closes
    them with the Outcome."""
    out, y0 = _Outputs.of(sched, t_end, view.y0.size, recorders), view.y0
    recording = _Recording(recorders, out, view)
    engine, n_done, failure = None, 0, None
    try:
        recording.through(0)  # the recorders' times at t = 0
        reason0 = view.initial_reason()
        if reason0:
            failure = (0.0, y0.copy(), reason0)
        else:
            engine = make_engine()
            n_done, failure = _advance(engine, out, bar, getattr(view, "max_abs_w", None), recording)
    except KeyboardInterrupt:  # before the engine started: nothing computed past t = 0
        engine = None
    except BaseException:
        recording.abandon()
        raise
    finally:
        if bar is not None:
            _close_bar(bar, failure, n_done < out.times.size, engine, t_end, recording.stop)
    return out, n_done, failure, engine, recording


def _run_native(rheology, scene, settings, t_end, times, choice, *, accuracy, material, advection, progress,
                series_times, scene_params) -> Result:
    """A run on the native engine (:mod:`icidr_pde.engines.native`); raises NativeUnavailable
    (before any work) where its library cannot be built."""
    from .engines.native import NativeEngine

    case = _native_case(rheology, scene, settings, material=material, advection=advection,
                        scene_params=scene_params)
    check_atol(settings["atol"], case.y0, settings["atol_asked"])
    sched = schedule(case.scene, t_end, times, series_times=series_times)
    start = _time.perf_counter()
    problem = case.problem()
    _check_stiffness(problem, case.y0, t_end)
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
                            check=case.check_state, linear_solver=choice.linear_solver, max_order=choice.max_order)

    out, n_done, failure, engine, _ = _drive(view, make_engine, sched, t_end, bar)
    wall, cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    outcome = _outcome(view, engine, out, n_done, failure, t_end, wall, compile_s, cpu)
    counts = problem.counts()
    if engine is not None:  # the linear solver the compiled problem set up
        choice = choice.solved_by(engine.linear_solver)
    recorded = _recorded(view, sched, out, n_done)
    return assemble(rheology=case.rheology.name, scene=case.scene, discretization=case.discretization, N=case.N,
                    z=case.z, mass=case.mass, material=case.rheology.material.to_dict(), t_end=t_end,
                    rtol=settings["rtol"], atol=settings["atol"], method="CVODE", choice=choice, accuracy=accuracy,
                    options={"advection": case.advection} if case.advection else {}, labels=sched.labels,
                    recorded=recorded, outcome=outcome,
                    counts=(counts["steps"], counts["rhs"], counts["jac"], counts["lu"]),
                    y0_data=case.fields(case.y0), plane=getattr(case, "plane", lambda data: {})(recorded.data))


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


def _run_scheme(case, settings, t_end, times, choice, *, accuracy, progress, series_times, backend,
                outputs=None):
    """A run of a py-pde case on a Python engine (scipy, scikit-sundae) driven by the run path:
    the engine advanced to each output time of the schedule and of the recorders of `outputs`
    (:func:`make_recorders`), no py-pde Controller or tracker. Returns (Result, recorders)."""
    from .engines import engine_class
    from .engines.base import StepStatistics
    from .engines.stiff import StiffSolver, check_memory, scheme_problem

    check_atol(settings["atol"], case.state.data, settings["atol_asked"])
    check_memory(case.pde, case.grid, settings["method"], choice)  # before the engine allocates
    sched = schedule(case.scene, t_end, times, series_times=series_times)
    recorders = make_recorders(case, t_end, snap_times=sched.snap_times, progress=progress, **(outputs or {}))
    bar = None
    if progress:
        from .progress import TimeBar

        bar = TimeBar(t_end, "compiling", log_interval=0.1)
    start, cpu_start = _time.perf_counter(), _time.process_time()
    stats = StepStatistics()
    try:
        rhs = StiffSolver(case.pde, method=settings["method"], rtol=settings["rtol"], atol=settings["atol"],
                          backend=backend, choice=choice).rates(case.state)
        rhs(np.array(case.state.data), 0.0)  # compile or load now, so that it counts as set-up time
        problem, ordering = scheme_problem(case.pde, case.state, choice, rhs, stats)
        _compile_jacobian(problem)
    except BaseException:
        for recorder in recorders:
            recorder.abandon()
        raise
    compile_s, compile_cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    if bar is not None:
        bar.integrating(f"compiled in {compile_s:.1f} s")
    view = _SchemeView(case, problem, ordering)

    def make_engine():
        return engine_class(choice.engine)(settings["method"], problem, 0.0, rtol=settings["rtol"],
                                           atol=settings["atol"], linear_solver=choice.linear_solver,
                                           max_order=choice.max_order)

    out, n_done, failure, engine, recording = _drive(view, make_engine, sched, t_end, bar, recorders)
    wall = _time.perf_counter() - start - compile_s
    cpu = _time.process_time() - cpu_start - compile_cpu
    outcome = _outcome(view, engine, out, n_done, failure, t_end, wall, compile_s, cpu, recording.stop)
    recording.close(outcome)
    method, ranks = settings["method"], 1
    if choice.engine == "petsc":  # PETSc's TS integrates whatever method was asked (choose.PETSC_METHOD)
        from .engines.choose import PETSC_METHOD

        method = PETSC_METHOD
    if engine is not None:
        stats.n_steps, stats.n_jac, stats.n_lu = engine.counts()
        choice = choice.solved_by(engine.linear_solver)
        method, ranks = engine.ran or method, engine.ranks
    recorded = _recorded(view, sched, out, n_done)
    result = assemble(rheology=case.pde.rheology.name, scene=case.scene, discretization=case.pde.name, N=case.N,
                      z=view.z, mass=case.mass, material=case.pde.material.to_dict(), t_end=t_end,
                      rtol=settings["rtol"], atol=settings["atol"], method=method, choice=choice,
                      accuracy=accuracy, options=case.pde.option_values(), labels=sched.labels, recorded=recorded,
                      outcome=outcome, counts=(stats.n_steps, stats.n_rhs, stats.n_jac, stats.n_lu),
                      y0_data=case.state.data, plane=_plane_kwargs(case, recorded.data), ranks=ranks)
    return result, recorders


def _compile_jacobian(problem) -> None:
    """Call the compiled analytic Jacobian once at y0: its first call compiles it (seconds on an
    empty cache), set-up time (compile_s) rather than the solve's (wall_s)."""
    spec, y0 = problem.jacobian, np.array(problem.y0)
    if spec.jac is not None:
        spec.jac(0.0, y0)
    elif spec.band_jac is not None and y0.size <= 3000:  # into a dense array: small grids only
        spec.band_jac(y0, np.zeros((y0.size, y0.size)))


def _close_bar(bar, failure, interrupted, engine, t_end, stop=None):
    if failure is not None:
        bar.close(failure[0], "failed", failure[2])
    elif stop is not None:  # a recorder ended the run (the wall-clock limit)
        bar.close(stop[2], "stopped", stop[1])
    elif interrupted:
        bar.close(engine.last_good()[0] if engine is not None else 0.0, "interrupted")
    else:
        bar.close(t_end)


def _outcome(view, engine, out: _Outputs, n_done, failure, t_end, wall, compile_s, cpu, stop=None) -> Outcome:
    if failure is not None:
        t_final, final = failure[0], view.fields(failure[1])
        return Outcome(final, True, float(t_final), failure[2], float(t_final), wall, compile_s, cpu)
    if stop is not None:  # a recorder ended the run at an output (its state is still kept)
        index, reason, t_final = stop
        y = view.y0 if index < 0 else out.states[out.store[index]]
        return Outcome(view.fields(y), False, None, reason, t_final, wall, compile_s, cpu)
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
    # the last states passed before the run ended: the series' ring and the kept snapshots
    ring = out.at_last[out.at_last < n_done][-LAST_STATES:]
    kept = [i for i in np.flatnonzero(out.store >= 0) if i < n_done and i not in out.at_last]
    kept = [i for i in kept if i not in set(np.concatenate(out.at_recorders or [np.empty(0, int)]).tolist())]
    last = sorted(set(int(i) for i in ring) | set(int(i) for i in kept))[-LAST_STATES:]
    recorded.last_times = np.array([float(out.times[i]) for i in last])
    recorded.last_states = np.array([fields(state_at(i)) for i in last]).reshape(len(last), *shape)
    return recorded


def _not_written(result: Result, name: str, path, why: str) -> None:
    result.not_written[name] = why
    warnings.warn(f"`{name}` {path} was not written: {why}", RuntimeWarning, stacklevel=3)
