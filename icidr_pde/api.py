"""One function to run a scene: build the discretized PDE, integrate, collect a Result."""

from __future__ import annotations

import time as _time

import numpy as np
from pde import FileStorage, MemoryStorage
from pde.solvers import Controller
from pde.trackers.trackers import PlotTracker, ProgressTracker

from .chebyshev import ChebyshevShearCellPDE
from .integrator import SimulationFailed, StiffSolver
from .pdes import ShearCellPDE
from .presets import resolve
from .result import Result
from .rheology import Material, get_rheology
from .scenes import get_scene
from .trackers import ChiTracker, MaxWTracker, dense_times

__all__ = ["run", "make_pde", "DISCRETIZATIONS"]


DISCRETIZATIONS = {"fd": ShearCellPDE, "cheb": ChebyshevShearCellPDE}


def make_pde(rheology="icidr", discretization="fd", material=None, **kwargs):
    """The shear-cell PDE for `rheology` discretized by `discretization` ('fd' or 'cheb')."""
    try:
        cls = DISCRETIZATIONS[discretization]
    except KeyError:
        raise ValueError(f"`discretization` must be one of {sorted(DISCRETIZATIONS)}; "
                         f"got {discretization!r}") from None
    return cls(get_rheology(rheology, material), **kwargs)


def _time_labels(times, t_end):
    labels, values = [], []
    for t in times:
        value = float(t)
        if not (np.isfinite(value) and 0 <= value <= t_end):
            raise ValueError(f"`times` must lie in [0, t_end] = [0, {t_end}]; got {t!r}")
        labels.append(t if isinstance(t, str) else f"{value:g}")
        values.append(value)
    order = np.argsort(values, kind="stable")
    return [labels[i] for i in order], np.array(values)[order]


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
    advection: str = "upwind",
    progress: bool = False,
    live_plot: bool = False,
    save: str | None = None,
    series_times=None,
    **scene_params,
) -> Result:
    """Run `scene` with `rheology` and return a :class:`~icidr_pde.result.Result`.

    Args:
        rheology: 'mui' ((3.13)-(3.15)) or 'icidr' ((5.3)-(5.5) with the pressure (4.12))
        scene: 'shear' (IC (3.16)) or 'sine' (IC (5.7)); scene parameters (phi0, eps,
            a, b, H) are keyword arguments
        N: number of grid cells ('fd') or collocation points with walls ('cheb')
        t_end: final time
        times: snapshot times (strings keep their spelling as labels)
        accuracy: preset 'draft', 'standard' or 'publication' (see :mod:`icidr_pde.presets`);
            it fills in discretization, N, method, rtol and atol where they are None
        discretization: 'fd' (finite volumes on py-pde's grid) or 'cheb' (Chebyshev)
        method: 'BDF', 'Radau', 'LSODA' (scipy) or 'CVODE' (SUNDIALS, the fast path)
        rtol, atol: integrator tolerances
        jacobian: 'analytic', 'sparse-fd', 'banded-fd' or 'none' (None: the method's best)
        material: parameters (default Table 1)
        advection: 'upwind' or 'central' (finite differences only)
        progress: show a progress bar
        live_plot: show the fields while they evolve (py-pde PlotTracker, e.g. in Jupyter)
        save: optional HDF5 file for the snapshots (py-pde FileStorage)
        series_times: times of the max|w| and chi series (default: dense log+linear)

    A failed run (step-size underflow, non-finite state, phi leaving (0, phi_c)) is not
    an exception: the Result has blew_up=True, t_star, reason, and all that was recorded.
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"`t_end` must be > 0; got {t_end}")
    settings = resolve(accuracy, discretization=discretization, N=N, method=method, rtol=rtol, atol=atol)
    discretization, N, method = settings["discretization"], settings["N"], settings["method"]
    rtol, atol = settings["rtol"], settings["atol"]
    scene_obj = get_scene(scene, **scene_params)
    pde_kwargs = {"advection": advection} if discretization == "fd" else {}
    if discretization != "fd" and advection != "upwind":
        raise ValueError("`advection` applies to discretization='fd' only")
    pde = make_pde(rheology, discretization, material, **pde_kwargs)
    pde.material.check_phi(scene_obj.phi0, "phi0")
    grid = pde.make_grid(N, scene_obj.H)
    z = pde.nodes(grid)
    state = pde.make_state(grid, *scene_obj.initial_condition(z))
    mass0 = pde.integral(state.data[0], grid)

    if times is None:
        times = [t for t in scene_obj.default_times if t <= t_end] + [t_end]
    labels, snap_times = _time_labels(times, t_end)
    storage = MemoryStorage()
    series = dense_times(t_end) if series_times is None else np.asarray(series_times, float)
    max_w = MaxWTracker(interrupts=list(series))
    trackers = [storage.tracker(interrupts=list(snap_times)), max_w]
    chi_tracker = None
    if "chi" in scene_obj.outputs:
        chi_times = np.unique(np.concatenate(([0.0], np.geomspace(min(1e-3, t_end / 10), t_end, 20))))
        chi_tracker = ChiTracker(pde, interrupts=list(chi_times))  # a few samples: chi is a diagnostic
        trackers.append(chi_tracker)
    if save:
        trackers.append(FileStorage(save, write_mode="truncate").tracker(interrupts=list(snap_times)))
    if progress:
        trackers.append(ProgressTracker(interrupts=max(t_end / 200, 1e-6)))
    if live_plot:
        trackers.append(PlotTracker(interrupts=t_end / 50, show=True))

    solver = StiffSolver(pde, method=method, rtol=rtol, atol=atol, jacobian=jacobian)
    controller = Controller(solver, t_range=(0.0, t_end), tracker=trackers)
    start = _time.perf_counter()
    try:
        final = controller.run(state).data.copy()  # run() works on a copy of `state`
        blew_up, t_star, reason, t_final = False, None, "reached t_end", t_end
    except SimulationFailed as failure:
        blew_up, t_star, reason, t_final = True, failure.t_star, failure.reason, failure.t_star
        final = failure.state_data
        max_w.times.append(t_star)
        max_w.values.append(float(np.max(np.abs(final[2]))))
        for tracker in trackers:  # close files and progress bars
            tracker.finalize()
    compile_s = solver.info.get("compile_s", 0.0)
    wall = _time.perf_counter() - start - compile_s  # numba compile time is reported apart

    data = np.array(storage.data) if len(storage) else np.empty((0, 3, len(z)))
    n_snap = data.shape[0]
    chi_kwargs = {}
    if chi_tracker is not None and chi_tracker.values:
        chi_kwargs = dict(chi_t=np.array(chi_tracker.times), chi_z=chi_tracker.z,
                          chi=np.array(chi_tracker.values))
    stats = solver.stats
    return Result(
        rheology=pde.rheology.name, scene=scene_obj.name, discretization=discretization,
        N=int(N), t_end=float(t_end), rtol=float(rtol), atol=float(atol), method=method,
        jacobian=solver.jacobian, blew_up=blew_up, t_star=t_star, reason=reason,
        t_final=float(t_final), z=z, times=np.array(storage.times[:n_snap]),
        time_labels=labels[:n_snap], requested_times=labels,
        phi=data[:, 0], u=data[:, 1], w=data[:, 2], final=tuple(final),
        max_w_t=np.array(max_w.times), max_w=np.array(max_w.values),
        mass_drift=(pde.integral(final[0], grid) - mass0) / mass0,
        wall_s=wall, compile_s=compile_s, n_steps=stats.n_steps, n_rhs=stats.n_rhs,
        n_jac=stats.n_jac, scene_params=scene_obj.parameters(),
        material=pde.material.to_dict(),
        settings=dict(accuracy=accuracy, **pde_kwargs),
        **chi_kwargs,
    )
