"""Stiff implicit time integration that keeps its state across tracker interrupts.

py-pde's stock ``scipy`` solver calls :func:`scipy.integrate.solve_ivp` afresh between
every two tracker interrupts, so BDF restarts at order 1 with a tiny step and a new
Jacobian each time. :class:`StiffSolver` instead holds one integrator for the whole run
(scipy's BDF, Radau or LSODA -- BDF being the analogue of MATLAB's ode15s used by the
paper -- or SUNDIALS CVODE, the compiled fast path), steps it past each interrupt and reads
the state there from its dense output.

A run fails (:class:`SimulationFailed`) when the integrator cannot meet its tolerances
(step-size underflow, the paper's 'non-convergent'), when the state becomes non-finite
or when phi leaves (0, phi_c). The failure carries the last accepted time t* and state.
"""

from __future__ import annotations

from dataclasses import dataclass

import time

import numpy as np
from pde.solvers.base import SolverBase
import scipy.integrate

__all__ = ["StiffSolver", "SimulationFailed", "METHODS", "JACOBIAN_MODES"]

METHODS = ("BDF", "Radau", "LSODA", "CVODE")
JACOBIAN_MODES = ("analytic", "sparse-fd", "banded-fd", "none")
DEFAULT_JACOBIAN = {"BDF": "analytic", "Radau": "analytic", "LSODA": "banded-fd", "CVODE": "banded-fd"}
_VALID_JACOBIANS = {
    "BDF": ("analytic", "sparse-fd", "none"),
    "Radau": ("analytic", "sparse-fd", "none"),
    "LSODA": ("analytic", "banded-fd", "none"),
    "CVODE": ("analytic", "banded-fd", "none"),
}


class SimulationFailed(RuntimeError):
    """The integration could not continue.

    Attributes:
        t_star: last accepted time
        reason: why the run stopped
        state_data: state at t_star
    """

    def __init__(self, t_star: float, reason: str, state_data: np.ndarray):
        super().__init__(f"simulation failed at t* = {t_star:.6g}: {reason}")
        self.t_star = t_star
        self.reason = reason
        self.state_data = state_data


@dataclass
class StepStatistics:
    """Counts of a run; n_steps is None for CVODE (scikit-sundae does not report it)."""

    n_steps: int | None = 0
    n_rhs: int = 0
    n_jac: int = 0
    n_lu: int = 0


def check_tolerances(rtol: float, atol: float) -> None:
    if not (np.isfinite(rtol) and 1e-14 <= rtol < 1):
        raise ValueError(f"`rtol` must lie in [1e-14, 1); got {rtol}")
    if not (np.isfinite(atol) and atol > 0):
        raise ValueError(f"`atol` must be > 0; got {atol}")


class _ScipyEngine:
    """One scipy OdeSolver (BDF, Radau, LSODA), checked after every accepted step."""

    def __init__(self, method, fun, t0, y0, options, margins=None):
        self.solver = getattr(scipy.integrate, method)(fun, t0, y0, np.inf, **options)
        self.t, self.y, self.n_steps = t0, np.array(y0), 0

    def advance(self, t_end, check):
        """Step past t_end; return (t_good, y_good, reason) on failure, else None."""
        solver = self.solver
        while solver.t < t_end:
            message = solver.step()
            reason = f"integrator failed ({message})" if solver.status == "failed" else check(solver.y)
            if reason:
                return self.t, self.y, reason
            self.t, self.y = solver.t, solver.y.copy()
            self.n_steps += 1
        return None

    def value_at(self, t):
        return self.y if t == self.t else self.solver.dense_output()(t)

    def counts(self):
        return self.n_steps, self.solver.njev, self.solver.nlu


class _CvodeEngine:
    """SUNDIALS CVODE (BDF, orders 1-5) via scikit-sundae: the compiled fast path.

    CVODE runs in compiled code from one interrupt to the next; leaving the valid state
    space is caught exactly by CVODE's root finding on the PDE's `validity_margins`
    (terminal events), other checks run at the interrupts. With the banded linear solver
    the Jacobian comes from CVODE's banded difference quotients (2 * band + 1 RHS calls).
    """

    def __init__(self, fun, t0, y0, options, margins=None):
        from sksundae.cvode import CVODE

        jac = options.pop("jac", None)
        # min_step: like scipy's "step size below the spacing of numbers" test; without it
        # CVODE halves h down to 1e-165 before giving up on a blow-up (seconds of work)
        kwargs = dict(method="BDF", rtol=options["rtol"], atol=options["atol"],
                      max_num_steps=1_000_000, min_step=1e-14)
        max_step = options.get("max_step", np.inf)
        kwargs["max_step"] = max_step if np.isfinite(max_step) else 1e300  # 0 ("none") < min_step
        if "first_step" in options:
            kwargs["first_step"] = options["first_step"]
        if "band" in options:
            kwargs.update(linsolver="band", lband=options["band"][0], uband=options["band"][1])
        elif jac is not None:
            def jacfn(t, y, yp, JJ):
                J = jac(t, y)
                JJ[:, :] = J.toarray() if hasattr(J, "toarray") else J

            kwargs.update(linsolver="lapackdense", jacfn=jacfn)
        if margins is not None:
            n_events = len(margins(y0))

            def eventsfn(t, y, events):
                events[:] = margins(y)

            eventsfn.terminal = [True] * n_events
            eventsfn.direction = [-1] * n_events
            kwargs.update(eventsfn=eventsfn, num_events=n_events)

        def rhsfn(t, y, yp):
            yp[:] = fun(t, y)

        self.solver = CVODE(rhsfn, **kwargs)
        self.solver.init_step(t0, y0)
        self.t, self.y, self.njev = t0, np.array(y0), 0

    def advance(self, t_end, check):
        result = self.solver.step(t_end, method="normal")
        self.njev = getattr(result, "njev", self.njev)
        y = np.array(result.y, dtype=float).ravel()
        if not result.success:
            if np.all(np.isfinite(y)) and float(result.t) > self.t:
                self.t, self.y = float(result.t), y
            return self.t, self.y, f"integrator failed ({result.message})"
        self.t, self.y = float(result.t), y
        if self.t < t_end:  # stopped at a terminal event: the state reached the boundary
            return self.t, self.y, check(y) or "state reached the boundary of its valid range"
        reason = check(y)
        return (self.t, self.y, reason) if reason else None

    def value_at(self, t):
        return self.y

    def counts(self):
        return None, self.njev, 0


class StiffSolver(SolverBase):
    """py-pde solver wrapping stiff implicit methods with one persistent integrator.

    Use as ``eq.solve(state, t_range, solver="stiff", method="BDF", rtol=1e-6)``.

    Args:
        pde: the PDE; it offers ``make_jacobian(state)`` (analytic), ``jacobian_sparsity``
            (for colored finite differences), optionally ``interleaving(state)``
            (permutation and bandwidths of a banded ordering) and ``check_state(data)``
            (a failure reason or None)
        method: 'BDF' (scipy, default, like ode15s), 'Radau', 'LSODA' (scipy) or 'CVODE'
            (SUNDIALS via scikit-sundae)
        rtol, atol: tolerances of the integrator
        jacobian: 'analytic', 'sparse-fd' (scipy's colored differences, BDF/Radau),
            'banded-fd' (LSODA/CVODE banded differences on the interleaved ordering) or
            'none' (dense differences, for comparison only); None picks the method's best
        max_step: largest step the integrator may take
        backend: py-pde backend for the right-hand side ('numba' by default)
    """

    name = "stiff"

    def __init__(
        self,
        pde,
        *,
        method: str = "BDF",
        rtol: float = 1e-6,
        atol: float = 1e-9,
        jacobian: str | None = None,
        max_step: float = np.inf,
        backend: str = "numba",
    ):
        super().__init__(pde, backend=backend)
        if method not in METHODS:
            raise ValueError(f"`method` must be one of {METHODS}; got {method!r}")
        self._default_jacobian = jacobian is None
        if jacobian is None:
            jacobian = DEFAULT_JACOBIAN[method]
        if jacobian not in _VALID_JACOBIANS[method]:
            raise ValueError(f"`jacobian` must be one of {_VALID_JACOBIANS[method]} for "
                             f"method {method!r}; got {jacobian!r}")
        check_tolerances(rtol, atol)
        if not max_step > 0:
            raise ValueError(f"`max_step` must be > 0; got {max_step}")
        self.method = method
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.jacobian = jacobian
        self.max_step = max_step
        self.stats = StepStatistics()
        self.last_good: tuple[float, np.ndarray] | None = None

    def _ordering(self, state, size: int):
        """Permutation into the integrator's ordering and the band, if banded."""
        if self.jacobian != "banded-fd":
            return None, None
        interleaving = getattr(self.pde, "interleaving", None)
        if interleaving is None or interleaving(state) is None:
            if self._default_jacobian:  # no banded ordering (e.g. Chebyshev): dense analytic
                self.jacobian = "analytic"
                return None, None
            raise ValueError("`jacobian`='banded-fd' needs a discretization with a banded "
                             "ordering (finite differences); use 'analytic' or 'none'")
        perm, lband, uband = interleaving(state)
        return perm, (lband, uband)

    def make_stepper(self, state, dt: float | None = None):
        """Return stepper(state, t_start, t_end) advancing one persistent integrator."""
        start = time.perf_counter()
        self._select_backend(state)
        rhs = self.backend.make_pde_rhs(self.pde, state)
        shape = state.data.shape
        rhs(np.array(state.data), 0.0)  # compile now, so that it counts as set-up time
        self.info["compile_s"] = time.perf_counter() - start  # wall clock, unlike py-pde's profiler
        stats = self.stats
        check_state = getattr(self.pde, "check_state", lambda data: None)
        perm, band = self._ordering(state, state.data.size)
        inverse = None if perm is None else np.argsort(perm)

        def to_native(y):  # integrator ordering -> (3, N) state data
            # always a fresh writable C array: a read-only or strided view (as CVODE passes)
            # would make numba compile a second specialisation in the middle of the run
            return (np.array(y, dtype=float) if perm is None else y[inverse]).reshape(shape)

        def fun(t, y):
            stats.n_rhs += 1
            rate = rhs(to_native(y), t).ravel()
            return rate if perm is None else rate[perm]

        options = dict(rtol=self.rtol, atol=self.atol, max_step=self.max_step)
        if dt is not None:
            options["first_step"] = dt
        if self.jacobian == "analytic":
            options["jac"] = self.pde.make_jacobian(state)
        elif self.jacobian == "sparse-fd":
            options["jac_sparsity"] = self.pde.jacobian_sparsity(state)
        if self.jacobian == "analytic" and self.method == "LSODA":  # Fortran wants dense
            any_jac = options["jac"]

            def dense_jac(t, y):
                J = any_jac(t, y)
                return J.toarray() if hasattr(J, "toarray") else J

            options["jac"] = dense_jac
        elif band is not None and self.method == "LSODA":
            options.update(lband=band[0], uband=band[1])
        elif band is not None:
            options["band"] = band
        self.info.update(method=self.method, rtol=self.rtol, atol=self.atol,
                         jacobian=self.jacobian, dt=None, steps=0)
        engines: list = []  # created lazily at the first call, at its t_start

        def check(y):
            if not np.all(np.isfinite(y)):
                return "state became non-finite"
            return check_state(to_native(y))

        pde_margins = getattr(self.pde, "validity_margins", None)
        margins = None if pde_margins is None else (lambda y: pde_margins(to_native(y)))

        def fail(reason: str):
            if engines:
                stats.n_steps, stats.n_jac, stats.n_lu = engines[0].counts()
            t_good, y_good = self.last_good
            raise SimulationFailed(t_good, reason, to_native(y_good).copy())

        def stepper(state, t_start: float, t_end: float) -> float:
            if not engines:
                y0 = np.array(state.data, dtype=float).ravel()
                y0 = y0 if perm is None else y0[perm]
                self.last_good = (t_start, y0.copy())
                reason = check(y0)
                if reason:
                    fail(f"initial state invalid: {reason}")
                if self.method == "CVODE":
                    engines.append(_CvodeEngine(fun, t_start, y0, dict(options), margins))
                else:
                    engines.append(_ScipyEngine(self.method, fun, t_start, y0, options))
            engine = engines[0]
            failure = engine.advance(t_end, check)
            if failure is not None:
                self.last_good = failure[:2]
                fail(failure[2])
            state.data[...] = to_native(engine.value_at(t_end))
            stats.n_steps, stats.n_jac, stats.n_lu = engine.counts()
            self.info.update(steps=stats.n_steps, n_rhs=stats.n_rhs)
            return t_end

        return stepper
