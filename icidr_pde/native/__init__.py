"""The native engine's compiled problems: a cell's scheme as C for SUNDIALS CVODE.

``run(..., method="CVODE")`` on a scheme with a compiled problem takes the native engine
(:class:`icidr_pde.engines.native.NativeEngine`, chosen by :func:`icidr_pde.engines.choose.choose`)
over the problem built here: same scheme, same CVODE settings, with no Python in the loop:
the law printed as C from its sympy definition (:mod:`icidr_pde.rheology.ccode`), the
scheme's right-hand side (and Jacobian) in C, printed from its numba template by
:mod:`.translate` (the scheme's one source), the cell's problem (its folder's ``problem.c``:
its linear solver) and a C driver that calls CVODE on any problem (``problem.h``,
``cvode_driver.c``), compiled once per installation and cell (:mod:`.build`). A warm run
imports neither py-pde, numba, scipy, sympy nor scikit-sundae: only numpy, ctypes and the
light parts of the package (rheology classes, scenes, presets, Result).

:class:`NativeProblem` is what every compiled problem shares; each cell binds its own in its
folder (:mod:`icidr_pde.cells`): the 1-D cell's finite volumes and Chebyshev collocation
(:mod:`icidr_pde.cells.shear1d.native`, :mod:`icidr_pde.cells.shear1d.native_cheb`), the 2-D
cell's finite volumes (:mod:`icidr_pde.cells.plane2d.native`).

Failure handling is the stiff solver's: a run that leaves (lo, hi) of phi (CVODE's root
function, exact crossing), fails in CVODE (the minimum step, repeated error-test or Newton
failures) or reaches an invalid state returns what it recorded, the time reached and the
reason; Ctrl-C ends it at CVODE's last step (C returns to Python every
:data:`STEPS_BETWEEN_SIGNALS` steps, where the signal is seen).

Building the library raises :class:`NativeUnavailable` where gcc, the SUNDIALS libraries or a C
form of the law are missing.
"""

from __future__ import annotations

import ctypes

import numpy as np

from ..cvode_settings import BDF_MAX_ORDER
from ..time_scale import MIN_STEP_FRACTION, fastest_time_scale
from .build import NativeUnavailable

__all__ = ["NativeUnavailable", "NativeProblem"]

#: CVODE's steps towards one output before the run fails (as scikit-sundae's engine is set)
MAX_STEPS = 1_000_000
#: C returns to Python after this many of CVODE's steps in one call (between two outputs or inside
#: one stretch), so that Ctrl-C or SIGTERM is seen within them (a long 2-D run with outputs only
#: at 0 and t_end would not see it before t_end); a return costs about one step of a small 1-D run
STEPS_BETWEEN_SIGNALS = 100
#: icidr_cvode_advance's status when it paused after STEPS_BETWEEN_SIGNALS steps
PAUSED = 4


def _pointer(array):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


class NativeProblem:
    """What the compiled problems of every cell share (their bindings are in the cells' folders,
    e.g. :class:`icidr_pde.cells.shear1d.native.FdProblem`): the
    library of `rheology`, its parameters and the valid range (lo, hi) of phi (`bounds`,
    default the law's), the right-hand side, the time scale, the kernels' timings, M(phi) and
    CVODE on the problem's handle. A subclass allocates the handle (:meth:`_attach`)."""

    #: repeats of :meth:`kernel_times` by default (fewer where a Jacobian is expensive)
    kernel_repeats = 200
    #: right-hand sides evaluated outside CVODE (the time scale of :meth:`start`)
    _own_rhs = 0

    def _open(self, rheology, bounds, kinematics):
        """The library of `rheology` in `kinematics` (its cell's), its parameters and (lo, hi) of phi."""
        from .build import library

        self.lib = library(rheology, kinematics)
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
        return self._estimate(np.ascontiguousarray(y, dtype=float), iterations)[0]

    def _estimate(self, y, iterations: int = 20) -> tuple[float, int]:
        """(time scale, right-hand sides it took) at `y`, the last one kept: the run path's
        stiffness check and :meth:`start` ask for the same state (the rates do not depend on t)."""
        kept = getattr(self, "_kept_estimate", None)
        if kept is not None and kept[0] == iterations and np.array_equal(kept[1], y):
            return kept[2], kept[3]
        evaluations = []
        scale = fastest_time_scale(lambda t, v: evaluations.append(1) or self.rates(v), 0.0, y, iterations)
        self._kept_estimate = (iterations, y.copy(), scale, len(evaluations))
        return scale, len(evaluations)

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
              first_step: float | None = None, max_order: int = BDF_MAX_ORDER) -> float:
        """Start CVODE (BDF, orders 1 to `max_order`) at (t0, y0) with the smallest step
        MIN_STEP_FRACTION x the fastest time scale 1/rho(J(y0)) (:meth:`time_scale`, its
        evaluations counted as the run's); returns that time scale."""
        y0 = np.ascontiguousarray(y0, dtype=float)
        scale, self._own_rhs = self._estimate(y0)
        error = ctypes.create_string_buffer(1024)
        status = self.lib.icidr_cvode_start(
            self.handle, t0, _pointer(y0), rtol, atol, MIN_STEP_FRACTION * scale,
            max_step if np.isfinite(max_step) else 1e300, MAX_STEPS, STEPS_BETWEEN_SIGNALS,
            0.0 if first_step is None else first_step,
            int(max_order), error, len(error))
        if status != 0:
            raise RuntimeError(f"CVODE could not start: {error.value.decode(errors='replace')}")
        return scale

    def advance(self, times, store, max_w, states):
        """CVODE through `times`; see icidr_cvode_advance. Returns (n_done, status, flag). Between
        two of C's pauses (every STEPS_BETWEEN_SIGNALS steps) Python raises a signal's exception
        that came meanwhile (KeyboardInterrupt): the run path then reports CVODE's last step."""
        times = np.ascontiguousarray(times, dtype=float)
        store = np.ascontiguousarray(store, dtype=np.intc)
        n_done, status, flag = ctypes.c_int(), ctypes.c_int(), ctypes.c_int()
        done = 0
        while True:
            self.lib.icidr_cvode_advance(self.handle, times.size - done, _pointer(times[done:]),
                                         store[done:].ctypes.data_as(ctypes.POINTER(ctypes.c_int)),
                                         _pointer(max_w[done:]), _pointer(states), ctypes.byref(n_done),
                                         ctypes.byref(status), ctypes.byref(flag))
            done += n_done.value
            if status.value != PAUSED:
                return done, status.value, flag.value

    def last_good(self) -> tuple[float, np.ndarray]:
        y = np.empty(3 * self.N)
        t = self.lib.icidr_cvode_last_good(self.handle, _pointer(y))
        return float(t), y

    def last_step(self) -> tuple[float, np.ndarray]:
        """(t, y) of CVODE's last accepted step (icidr_cvode_last_step: at or past the last output,
        the last output's before the first step)."""
        y = np.empty(3 * self.N)
        t = self.lib.icidr_cvode_last_step(self.handle, _pointer(y))
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
