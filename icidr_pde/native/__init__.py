"""The native engine: the 1-D shear cell integrated by SUNDIALS CVODE in compiled code.

:func:`run_native` runs what ``run(..., discretization="fd", method="CVODE")`` runs (same
scheme, same CVODE settings, same output times and Result) with no Python in the loop:
the law printed as C from its sympy definition (:mod:`icidr_pde.rheology.ccode`), the
finite-volume right-hand side and analytic band Jacobian in C, printed from the numba
template ``discretizations/templates/fd.py`` by :mod:`.translate` (the scheme's one source),
and a C driver that
calls CVODE (``cvode_driver.c``), compiled once per installation (:mod:`.build`). A warm
run imports neither py-pde, numba, scipy, sympy nor scikit-sundae: only numpy, ctypes and
the light parts of the package (rheology classes, scenes, presets, Result).

Chebyshev collocation (``discretization="cheb"``) runs the same way (:mod:`.cheb`):
the C printed from ``templates/cheb.py`` (the right-hand side and the dense Jacobian), with
the py-pde path's points, differentiation matrix and walls (:mod:`icidr_pde.discretizations.chebyshev`), and
CVODE's dense LU (LAPACK's where scikit-sundae ships it) kept as the py-pde path keeps it.

The walls are the ghost-cell maps of :meth:`ShearCellPDE.ghost_coefficients` (a test
compares them with py-pde's boundary setters); the grid is py-pde's cell-centred
``CartesianGrid([[0, H]], N)``. Failure handling is the stiff solver's: a run that leaves
(lo, hi) of phi (CVODE's root function, exact crossing), fails in CVODE (the minimum step,
repeated error-test or Newton failures) or reaches an invalid state returns what it
recorded, the time reached and the reason; Ctrl-C ends it at the last output reached.

:func:`unavailable` says in one line why a run cannot take this engine (another
discretization or method, a 2-D scene, an output only the py-pde path writes); building
the library raises :class:`NativeUnavailable` where gcc, the SUNDIALS libraries or a C
form of the law are missing.
"""

from __future__ import annotations

import ctypes
import sys
import time as _time

import numpy as np

from ..discretizations.grid_size import FD
from ..time_scale import MIN_STEP_FRACTION, fastest_time_scale
from ..discretizations.fd_core import ghost_coefficients
from .build import NativeUnavailable

__all__ = ["run_native", "try_native", "ENGINES", "unavailable", "NativeUnavailable", "NativeProblem", "FdProblem", "FdCase", "NativeCase", "ghost_coefficients",
           "MAX_N"]

MAX_N = FD.max_N
#: output times per call into C, adapted to take 0.02-0.1 s a call: Ctrl-C and the progress bar
#: act between calls, and a call costs ~1 us of Python
_CHUNK = (8, 1, 1024)  # first, smallest, largest


#: --engine choices: 'auto' takes the native engine where it applies, 'native' says why it did not,
#: 'pde' is the py-pde run path (api.run)
ENGINES = ("auto", "native", "pde")


def try_native(engine, rheology="icidr", scene="shear", N=None, t_end=10.0, times=None, *, accuracy="standard",
               discretization=None, method=None, rtol=None, atol=None, jacobian=None, material=None,
               advection=None, progress=False, series_times=None, save=None, movie=None, live_plot=False,
               max_wall=None, backend="numba", **scene_params):
    """The Result of the native engine, or None where the run takes the py-pde path.

    `engine`: one of :data:`ENGINES`. With 'auto' a run that the engine does not cover (see
    :func:`unavailable`) falls back silently; with 'native' one line on stderr says why. Where
    the engine applies but cannot be built (no compiler, no SUNDIALS libraries, a law without
    a C form) the line is printed in both cases."""
    from ..presets import resolve
    from ..scenes import SCENES
    from ..validation import choice

    choice("engine", engine, ENGINES)
    if engine == "pde":
        return None
    scene_cls = scene if not isinstance(scene, str) else SCENES.get(scene)
    if discretization is None:  # a scene of the 2-D cell names its scheme
        discretization = getattr(scene_cls, "discretization", None)
    settings = resolve(accuracy, discretization=discretization, N=None if isinstance(N, (tuple, list)) else N,
                       method=method, rtol=rtol, atol=atol)
    why = unavailable(discretization=settings["discretization"], method=settings["method"], jacobian=jacobian,
                      backend=backend, save=save, movie=movie, live_plot=live_plot, max_wall=max_wall, N=N,
                      scene=scene_cls)
    if why is None:
        try:
            return run_native(rheology, scene, N, t_end, times, accuracy=accuracy, discretization=discretization,
                              method=method, rtol=rtol, atol=atol, jacobian=jacobian, material=material,
                              advection=advection, progress=progress, series_times=series_times, **scene_params)
        except NativeUnavailable as err:
            sys.stderr.write(f"icidr-pde: native engine not available ({err}); running the py-pde path\n")
            return None
    if engine == "native":
        sys.stderr.write(f"icidr-pde: native engine not used: {why}; running the py-pde path\n")
    return None


def unavailable(*, discretization, method, jacobian=None, backend="numba", save=None, movie=None,
                live_plot=False, max_wall=None, N=None, scene=None) -> str | None:
    """Why these run settings cannot take the native engine (one line), or None."""
    if discretization not in ("fd", "cheb"):
        return f"discretization {discretization!r} (the native engine is the 1-D cell: fd or cheb)"
    if method != "CVODE":
        return f"method {method!r} (the native engine is CVODE)"
    if jacobian not in (None, "analytic"):
        return f"jacobian {jacobian!r} (the native engine uses the analytic Jacobian)"
    if backend != "numba":
        return f"backend {backend!r}"
    if isinstance(N, (tuple, list)):
        return "a 2-D grid"
    if getattr(scene, "dim", 1) != 1:
        return "a 2-D scene"
    for what, value in (("--save", save), ("--movie", movie), ("a live plot", live_plot),
                        ("a wall-clock limit", max_wall)):
        if value:
            return f"{what} (written by the py-pde run path)"
    return None


def _pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class NativeProblem:
    """What the compiled problems share (:class:`FdProblem`, :class:`~.cheb.ChebProblem`): the
    library of `rheology`, its parameters and the valid range (lo, hi) of phi (`bounds`,
    default the law's), the right-hand side, the time scale, the kernels' timings, M(phi) and
    CVODE on the problem's handle. A subclass allocates the handle (:meth:`_attach`)."""

    #: repeats of :meth:`kernel_times` by default (fewer where a Jacobian is expensive)
    kernel_repeats = 200
    #: right-hand sides evaluated outside CVODE (the time scale of :meth:`start`)
    _own_rhs = 0

    def _open(self, rheology, bounds):
        from ..rheology import SHEAR_CELL
        from .build import library

        self.lib = library(rheology, SHEAR_CELL)
        self._params = np.array(rheology.material.params, dtype=float)
        lo, hi = (float(b) for b in (rheology.material.phi_range if bounds is None else bounds))
        self.bounds = (lo, hi)
        return self._params, lo, hi

    def _attach(self, handle):
        if not handle:
            raise MemoryError(f"native problem of N = {self.N} not allocated")
        self.handle = handle

    def __del__(self):
        handle, self.handle = getattr(self, "handle", None), None
        if handle:
            self.lib.icidr_free(handle)

    def rates(self, y) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty(3 * self.N)
        self.lib.icidr_rates(self.handle, _pointer(y), _pointer(out))
        return out

    def time_scale(self, y, iterations: int = 20) -> float:
        """1/rho(J(y)) of the compiled right-hand side (the stiff solvers' estimate,
        :func:`icidr_pde.time_scale.fastest_time_scale`)."""
        return fastest_time_scale(lambda t, v: self.rates(v), 0.0, y, iterations)

    def kernel_times(self, y, repeats: int | None = None) -> tuple[float, float]:
        """Best-of-`repeats` seconds of one right-hand side and one Jacobian, timed in C."""
        y = np.ascontiguousarray(y, dtype=float)
        out = np.empty(2)
        self.lib.icidr_kernel_times(self.handle, _pointer(y), repeats or self.kernel_repeats, _pointer(out))
        return float(out[0]), float(out[1])

    def M(self, phi) -> np.ndarray:
        phi = np.ascontiguousarray(phi, dtype=float)
        out = np.empty(phi.size)
        self.lib.icidr_law_M(self.handle, phi.size, _pointer(phi), _pointer(out))
        return out

    # --- CVODE ------------------------------------------------------------------------------

    def start(self, y0, *, rtol: float, atol: float, t0: float = 0.0, max_step: float = np.inf,
              first_step: float | None = None) -> float:
        """Start CVODE at (t0, y0) with the smallest step MIN_STEP_FRACTION x the fastest time
        scale 1/rho(J(y0)) (:meth:`time_scale`, its evaluations counted as the run's); returns
        that time scale."""
        y0 = np.ascontiguousarray(y0, dtype=float)
        evaluations = []
        scale = fastest_time_scale(lambda t, v: evaluations.append(1) or self.rates(v), t0, y0)
        self._own_rhs = len(evaluations)
        error = ctypes.create_string_buffer(1024)
        status = self.lib.icidr_cvode_start(
            self.handle, t0, _pointer(y0), rtol, atol, MIN_STEP_FRACTION * scale,
            max_step if np.isfinite(max_step) else 1e300, 1_000_000, 0.0 if first_step is None else first_step,
            error, len(error))
        if status != 0:
            raise RuntimeError(f"CVODE could not start: {error.value.decode(errors='replace')}")
        return scale

    def advance(self, times, store, max_w, states):
        """CVODE through `times`; see icidr_cvode_advance. Returns (n_done, status, flag)."""
        times = np.ascontiguousarray(times, dtype=float)
        store = np.ascontiguousarray(store, dtype=np.intc)
        n_done, status, flag = ctypes.c_int(), ctypes.c_int(), ctypes.c_int()
        self.lib.icidr_cvode_advance(self.handle, times.size, _pointer(times),
                                     store.ctypes.data_as(ctypes.POINTER(ctypes.c_int)), _pointer(max_w),
                                     _pointer(states), ctypes.byref(n_done), ctypes.byref(status),
                                     ctypes.byref(flag))
        return n_done.value, status.value, flag.value

    def last_good(self) -> tuple[float, np.ndarray]:
        y = np.empty(3 * self.N)
        t = self.lib.icidr_cvode_last_good(self.handle, _pointer(y))
        return float(t), y

    def message(self, flag: int) -> str:
        out = ctypes.create_string_buffer(2048)
        self.lib.icidr_cvode_message(self.handle, flag, out, len(out))
        return " ".join(out.value.decode(errors="replace").split())

    def counts(self) -> dict:
        out = (ctypes.c_long * 7)()
        self.lib.icidr_cvode_counts(self.handle, out)
        out[1] += self._own_rhs
        return dict(zip(("steps", "rhs", "jac", "lu", "error_test_failures", "newton_iterations",
                         "newton_failures"), map(int, out)))


class FdProblem(NativeProblem):
    """The compiled finite-volume problem of `rheology` on N cells of height H (interleaved
    vector y[3 i + k]): right-hand side, band Jacobian, M(phi), and CVODE; valid while
    lo < phi < hi, `bounds` (default: the law's range of phi).

    The band is ``jb[col, row - col + 5]`` (11 entries a column, :meth:`jacobian_band`);
    :meth:`jacobian_dense` spreads it into the (3N, 3N) matrix."""

    def __init__(self, rheology, N: int, H: float, *, advection: str = "upwind", V0: float = 1.0, bounds=None):
        params, lo, hi = self._open(rheology, bounds)
        self.N, self.H, self.h = int(N), float(H), float(H) / int(N)
        self.ghost = np.ascontiguousarray(ghost_coefficients(V0))
        self._attach(self.lib.icidr_fd_problem(self.N, self.h, int(advection == "upwind"), _pointer(self.ghost),
                                               _pointer(params), params.size, lo, hi))

    def jacobian_band(self, y) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=float)
        jb = np.empty((3 * self.N, 11))
        self.lib.icidr_fd_jacobian(self.handle, _pointer(y), _pointer(jb))
        return jb

    def jacobian_dense(self, y) -> np.ndarray:
        jb, n = self.jacobian_band(y), 3 * self.N
        J = np.zeros((n, n))
        for offset in range(-5, 6):
            cols = np.arange(max(0, -offset), min(n, n - offset))
            J[cols + offset, cols] = jb[cols, offset + 5]
        return J


class NativeCase:
    """A 1-D case on the native engine: :func:`icidr_pde.case.build_case`'s scene and scheme
    core (its checks, nodes, walls, initial data, quadrature, strain rates and validity), with
    the engine's state vector y (the core's ``pack``: interleaved for fd, blocks for cheb)."""

    discretization = ""

    def __init__(self, rheology, scene, N, *, material=None, advection=None, scene_params=None):
        from ..case import build_case
        from ..scenes import get_scene

        if getattr(get_scene(scene, **(scene_params or {})), "dim", 1) != 1:
            raise NativeUnavailable("a 2-D scene")
        options = {} if advection is None else {"advection": advection}
        case = build_case(rheology, scene, self.discretization, N, material=material, options=options,
                          scene_params=scene_params)
        self.scheme, self.scene = case.scheme, case.scene
        self.rheology, self.N, self.H, self.V0 = self.scheme.rheology, self.scheme.N, self.scheme.H, self.scheme.V0
        self.z = self.scheme.z
        self.advection = self.scheme.option_values.get("advection")
        self.y0 = self.scheme.pack(case.data)

    def fields(self, y) -> np.ndarray:
        """(3, N) fields of the state vector `y`."""
        return self.scheme.unpack(y)

    def phi(self, y) -> np.ndarray:
        return self.scheme.phi_of(y)

    def mass(self, data) -> float:
        """The scheme's integral of phi."""
        return self.scheme.mass(data)

    def strain_rates(self, data):
        """Where the stresses live and (phi, u_z, w_z) there."""
        return self.scheme.strain_rates(data)

    def check_state(self, y) -> str | None:
        """Why the state `y` is invalid (as the stiff solver's check), or None."""
        if not np.all(np.isfinite(y)):
            return "state became non-finite"
        return self.scheme.check_state(self.fields(y))


class FdCase(NativeCase):
    """A finite-volume case (``discretization="fd"``, option ``advection``) on the native engine."""

    discretization = "fd"

    def problem(self) -> FdProblem:
        return FdProblem(self.rheology, self.N, self.H, advection=self.advection, V0=self.V0)


def _outputs(t_end, lists):
    """Merged output times (> 0, increasing; times within :func:`~icidr_pde.times.time_tolerance`
    are one output, as the stiff solver's recorders) and, per list, the output index of each of
    its times (-1: at t = 0)."""
    from ..times import time_tolerance

    every = np.sort(np.concatenate([np.asarray(t, float) for t in lists] + [[t_end]]))
    merged = []
    for t in every:
        if t < time_tolerance(0.0):
            continue
        if not merged or t >= merged[-1] + time_tolerance(merged[-1]):
            merged.append(float(t))
    merged = np.array(merged)
    where = []
    for times in lists:
        times = np.asarray(times, float)
        tolerance = np.array([time_tolerance(t) for t in times])
        index = np.searchsorted(merged, times - tolerance, side="left")
        index[times < time_tolerance(0.0)] = -1
        where.append(index)
    return merged, where


def _outputs_reached(problem, out_times, max_w, n_done: int) -> int:
    """Outputs done when Ctrl-C came: the signal is seen only once CVODE has returned, possibly
    before Python counted the outputs of that call (the driver wrote them and keeps the last)."""
    reached = int(np.searchsorted(out_times, problem.last_good()[0], side="right"))
    while reached > n_done and not np.isfinite(max_w[reached - 1]):  # stopped on an invalid state
        reached -= 1
    return max(n_done, reached)


def run_native(rheology="icidr", scene="shear", N=None, t_end=10.0, times=None, *, accuracy="standard",
               discretization=None, method=None, rtol=None, atol=None, jacobian=None, material=None,
               advection=None, progress=False, series_times=None, **scene_params):
    """Run one case on the native engine; arguments and Result as :func:`icidr_pde.api.run`.

    Raises :class:`NativeUnavailable` (before any work is done) where the case cannot take
    it (:func:`unavailable`, or the library cannot be built)."""
    from ..presets import resolve
    from ..result import Result
    from ..rheology.base import chi_of_M
    from ..times import check_t_end, dense_times, time_labels
    from ..validation import check_atol, nonfinite_rates, real

    t_end = check_t_end(t_end)
    settings = resolve(accuracy, discretization=discretization, N=N, method=method, rtol=rtol, atol=atol)
    why = unavailable(discretization=settings["discretization"], method=settings["method"], jacobian=jacobian,
                      N=settings["N"])
    if why:
        raise NativeUnavailable(why)
    if settings["discretization"] == "cheb":
        from .cheb import ChebCase as case_class
    else:
        case_class = FdCase
    case = case_class(rheology, scene, settings["N"], material=material, advection=advection,
                      scene_params=scene_params)
    rtol_v, atol_v = real("rtol", settings["rtol"], 1e-14, 1, low_open=False), real("atol", settings["atol"], 0)
    check_atol(atol_v, case.y0)
    if times is None:
        times = [t for t in case.scene.default_times if t <= t_end] + [t_end]
    labels, snap_times = time_labels(times, t_end)
    series = dense_times(t_end) if series_times is None else np.sort(np.asarray(series_times, float))
    chi_times = np.empty(0)
    if "chi" in case.scene.outputs:
        chi_times = np.unique(np.concatenate(([0.0], np.geomspace(min(1e-3, t_end / 10), t_end, 20))))

    start = _time.perf_counter()
    problem = case.problem()
    compile_s = _time.perf_counter() - start
    start, cpu_start = _time.perf_counter(), _time.process_time()

    out_times, (at_series, at_snap, at_chi) = _outputs(t_end, [series, snap_times, chi_times])
    n_out, n3 = out_times.size, 3 * case.N
    stored = np.unique(np.concatenate([at_snap, at_chi, [n_out - 1]]).astype(int))
    stored = stored[stored >= 0]
    store = np.full(n_out, -1, dtype=np.intc)
    store[stored] = np.arange(stored.size)
    states = np.empty((max(stored.size, 1), n3))
    max_w = np.full(n_out, np.nan)
    y0 = case.y0
    lo, hi = problem.bounds
    failure = None
    n_done = 0
    phi0 = case.fields(y0)[0]
    inside0 = np.all(np.isfinite(y0)) and np.all((phi0 > lo) & (phi0 < hi))
    bar = None
    if progress:
        from ..progress import TimeBar

        # refreshed every 0.1 s also into a pipe, as tqdm does by default: a reader sees the time move
        bar = TimeBar(t_end, "integrating", f"native, ready in {compile_s:.2g} s", log_interval=0.1)
    started = False
    try:
        reason0 = (f"initial state invalid: {case.check_state(y0)}" if not inside0
                   else nonfinite_rates(case.fields(problem.rates(y0))))
        if reason0:
            failure = (0.0, y0.copy(), reason0)
        else:
            problem.start(y0, rtol=rtol_v, atol=atol_v)
            started = True
            size, smallest, largest = _CHUNK
            while n_done < n_out and failure is None:
                chunk = slice(n_done, min(n_done + size, n_out))
                call = _time.perf_counter()
                done, status, flag = problem.advance(out_times[chunk], store[chunk], max_w[n_done:], states)
                call = _time.perf_counter() - call
                size = min(2 * size, largest) if call < 0.02 else max(size // 2, smallest) if call > 0.1 else size
                n_done += done
                if bar is not None and n_done:
                    bar.advance(out_times[n_done - 1])
                if status:
                    t_good, y_good = problem.last_good()
                    if status == 1:
                        reason = case.check_state(y_good) or "state reached the boundary of its valid range"
                    elif status == 2:
                        reason = f"integrator failed ({problem.message(flag)})"
                    else:
                        reason = case.check_state(y_good)
                    failure = (t_good, y_good, reason)
    except KeyboardInterrupt:
        if started:
            n_done = _outputs_reached(problem, out_times, max_w, n_done)
    finally:
        interrupted = failure is None and n_done < n_out
        if bar is not None:
            if failure is not None:
                bar.close(failure[0], "failed", failure[2])
            elif interrupted:
                bar.close(problem.last_good()[0] if n_done else 0.0, "interrupted")
            else:
                bar.close(t_end)
    wall, cpu = _time.perf_counter() - start, _time.process_time() - cpu_start
    counts = problem.counts()

    native = case.fields

    def state_at(index):
        return y0 if index < 0 else states[store[index]]

    def done(index):
        return index < n_done

    # one snapshot per distinct time, labelled by the first labels (as py-pde's storage records them)
    snaps = [k for k, index in enumerate(at_snap) if done(index) and (k == 0 or snap_times[k] > snap_times[k - 1])]
    data = np.array([native(state_at(at_snap[k])) for k in snaps]).reshape(len(snaps), 3, case.N)
    series_done = [k for k, index in enumerate(at_series) if done(index)]
    max_w_t = [float(out_times[at_series[k]]) if at_series[k] >= 0 else float(series[k]) for k in series_done]
    max_w_v = [float(max_w[at_series[k]]) if at_series[k] >= 0 else float(np.max(np.abs(native(y0)[2])))
               for k in series_done]
    if failure is not None:
        t_final, final = failure[0], native(failure[1])
        max_w_t.append(float(t_final))
        max_w_v.append(float(np.max(np.abs(final[2]))))
        blew_up, t_star, reason = True, float(t_final), failure[2]
    elif interrupted:  # the last output state CVODE returned (the driver keeps it)
        t_final, y_last = problem.last_good() if started else (0.0, y0)
        final = native(y_last)
        blew_up, t_star, reason = False, None, f"interrupted at t = {t_final:.6g}"
    else:
        t_final, final = float(t_end), native(states[store[n_out - 1]])
        blew_up, t_star, reason = False, None, "reached t_end"
    chi_kwargs = {}
    chi_done = [k for k, index in enumerate(at_chi) if done(index)]
    if chi_done:
        values = []
        for k in chi_done:
            with np.errstate(all="ignore"):  # a state overflowing the strain rates has chi = inf or nan
                z_f, phi_f, uz, wz = case.strain_rates(native(state_at(at_chi[k])))
                values.append(chi_of_M(problem.M(phi_f), uz, wz))
        chi_kwargs = dict(chi_t=np.array([float(chi_times[k]) for k in chi_done]), chi_z=z_f, chi=np.array(values))
    mass0 = case.mass(native(y0))
    return Result(
        rheology=case.rheology.name, scene=case.scene.name, discretization=case.discretization, N=case.N, t_end=float(t_end),
        rtol=float(rtol_v), atol=float(atol_v), method="CVODE", jacobian="analytic", blew_up=blew_up,
        t_star=t_star, reason=reason, t_final=float(t_final), z=case.z, times=np.array(snap_times[snaps]),
        time_labels=labels[:len(snaps)], requested_times=labels, phi=data[:, 0], u=data[:, 1],
        w=data[:, 2], final=tuple(final), max_w_t=np.array(max_w_t), max_w=np.array(max_w_v),
        mass_drift=(case.mass(final) - mass0) / mass0, wall_s=wall, compile_s=compile_s, cpu_s=cpu,
        n_steps=counts["steps"], n_rhs=counts["rhs"], n_jac=counts["jac"], n_lu=counts["lu"],
        scene_params=case.scene.parameters(), material=case.rheology.material.to_dict(),
        settings=dict(accuracy=accuracy, **({"advection": case.advection} if case.advection else {}),
                      engine="native"), **chi_kwargs)
