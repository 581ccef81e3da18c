"""SUNDIALS CVODE through scikit-sundae behind the :class:`~.base.Engine` protocol: the linear
solver of :mod:`.linear` that the run's choice names sets CVODE's options, SUNDIALS' messages
captured into the failure reason, CVODE's own counters (:mod:`.cvode_counters`)."""

from __future__ import annotations

import io
import sys

import numpy as np

from . import cvode_counters
from .base import DENSE_LU_DELTA_GAMMA, KRYLOV_EPS_LIN, Engine, Problem  # noqa: F401  (the settings of this engine's solvers)
from .linear import named
from .linear.dense_lu import CvodeDenseQuotients
from .linear.base import fun_into
from ..cvode_settings import BDF_MAX_ORDER
from ..time_scale import MIN_STEP_FRACTION

__all__ = ["CvodeEngine", "KRYLOV_EPS_LIN"]

class _CapturedOutput:
    """Collect what scikit-sundae prints (its SUNDIALS error handler calls Python's print)."""

    def __init__(self):
        self.buffer = io.StringIO()

    def __enter__(self):
        self.saved, sys.stdout = sys.stdout, self.buffer
        return self

    def __exit__(self, *exc):
        sys.stdout = self.saved
        return False

    def take(self) -> str:
        """The text printed so far (and forget it)."""
        text = self.buffer.getvalue()
        if text:
            self.buffer.seek(0)
            self.buffer.truncate()
        return " ".join(text.split())


class CvodeEngine(Engine):
    """SUNDIALS CVODE (BDF, orders 1 to `max_order` <= 5) via scikit-sundae: the compiled fast path.

    CVODE runs in compiled code from one interrupt to the next; leaving the valid state
    space is caught exactly by CVODE's root finding on the `margins` (terminal events),
    other checks run at the interrupts. 'analytic' on a banded discretization (the
    default where the discretization offers ``make_band_jacobian``): the compiled
    analytic Jacobian written into CVODE's band matrix and its band LU (no difference
    quotients; exact column sums of the conservative rows, so the Newton corrections
    conserve mass to round-off); 'analytic' otherwise (Chebyshev): the dense analytic
    Jacobian and LAPACK's dense LU, kept until gamma has changed by :data:`DENSE_LU_DELTA_GAMMA`; 'banded-fd': banded difference quotients (2 * band + 1 RHS calls
    per Jacobian) computed here with exact mass-row column sums, so that the Newton updates
    conserve mass to round-off (SUNDIALS' own quotients drift it by 2.6e-11 at N = 7; kept
    above 256 MiB of Jacobian, where scikit-sundae's dense hand-over array would not fit). On 2-D grids ('krylov') GMRES solves
    the Newton systems matrix-free, far faster on iCIDR bump2d than SuperLU_MT with the
    analytic Jacobian ('sparse'; the times: docs/sim2d.md); 'amg'
    preconditions that GMRES by one algebraic-multigrid V-cycle (:mod:`.linear.amg`), 'fourier' by the
    exact inverse of the x-averaged Jacobian's Newton matrix (:mod:`.linear.xfourier`).
    SUNDIALS' messages are captured into the failure reason. The minimum step is relative
    to the problem's fastest time scale (:func:`fastest_time_scale`).
    """

    name = "sundae"
    methods = ("CVODE",)

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver=CvodeDenseQuotients(), max_order=BDF_MAX_ORDER):  # a LinearSolver or its name
        from sksundae.cvode import CVODE

        # min_step: without one CVODE halves h down to 1e-165 before giving up on a blow-up
        # (seconds of work). It is relative to the problem's fastest time scale, as scipy's
        # spacing test is relative to t: a fixed 1e-14 stopped iCIDR at t* = 0 near jamming
        # and in tiny cells, whose time scales are 1e-14 to 1e-13.
        self.time_scale = problem.time_scale(t0)
        kwargs = dict(method="BDF", rtol=rtol, atol=atol, max_num_steps=1_000_000, max_order=int(max_order),
                      min_step=MIN_STEP_FRACTION * self.time_scale,
                      max_step=max_step if np.isfinite(max_step) else 1e300)  # 0 ("none") < min_step
        if first_step is not None:
            kwargs["first_step"] = first_step
        solver = named(linear_solver)  # a LinearSolver, or the name of one
        kwargs.update(solver.cvode_options(problem, rtol, atol))
        kwargs.update(_events(problem))
        self.problem = problem
        self.linear_solver = solver.set_up_name(kwargs)  # what it is on this problem (the line preconditioner's)
        self.interrupt = None
        self.output = _CapturedOutput()
        self.log: list[str] = []
        self.solver = CVODE(self._rhsfn(problem), **kwargs)
        start = self.solver.init_step(t0, problem.y0)
        self.counters = cvode_counters.attach(self.solver, start.nfev)
        if solver.krylov and self.counters is not None:
            self.counters.set_eps_lin(KRYLOV_EPS_LIN)
        if solver.delta_gamma is not None and self.counters is not None:
            self.counters.set_lsetup_reuse(delta_gamma=solver.delta_gamma)
        self.t, self.y, self.njev = t0, np.array(problem.y0), 0

    def _rhsfn(self, problem):
        rates_into = fun_into(problem)

        def rhsfn(t, y, yp):
            try:
                rates_into(t, y, yp)
            except KeyboardInterrupt as interrupt:  # re-raised once CVODE has returned
                self.interrupt = interrupt
                raise

        return rhsfn

    def advance(self, t_end):
        check = self.problem.check
        with self.output:  # SUNDIALS' messages belong in the result, not on the terminal
            result = self.solver.step(t_end, method="normal")
        printed = self.output.take()
        if printed:
            self.log.append(printed)
        if self.interrupt is not None:
            raise self.interrupt
        self.njev = getattr(result, "njev", self.njev)
        y = np.array(result.y, dtype=float).ravel()
        if not result.success:
            if np.all(np.isfinite(y)) and float(result.t) > self.t:
                self.t, self.y = float(result.t), y
            detail = f"; SUNDIALS: {printed}" if printed else ""
            return self.t, self.y, f"integrator failed ({result.message}{detail})"
        self.t, self.y = float(result.t), y
        if self.t < t_end:  # stopped at a terminal event: the state reached the boundary
            return self.t, self.y, check(y) or "state reached the boundary of its valid range"
        reason = check(y)
        return (self.t, self.y, reason) if reason else None

    def value_at(self, t):
        return self.y

    def last_step(self):
        """(t, y) of CVODE's last accepted step (:meth:`.cvode_counters.CvodeCounters.last_step`)
        where that state passes the problem's check. Else the last output's (:meth:`last_good`):
        without CVODE's counters (scikit-sundae's memory not found), before the first step, or a
        state the root function and the check did not pass (an interrupt between them)."""
        return self._checked_step(None if self.counters is None else self.counters.last_step(self.problem.y0.size))

    def counts(self):
        if self.counters is None:
            return None, self.njev, None
        return self.counters.get("steps"), self.counters.get("jac"), self.counters.get("lu")


def _events(problem) -> dict:
    """CVODE's root function on the validity margins: leaving the valid states ends a step exactly."""
    if problem.margins is None:
        return {}
    n_events = len(problem.margins(problem.y0))
    margins_into = problem.margins_into
    if margins_into is None:
        margins = problem.margins

        def margins_into(y, events):
            events[:] = margins(y)

    def eventsfn(t, y, events):  # the root function runs at every step: no temporaries
        margins_into(y, events)

    eventsfn.terminal = [True] * n_events
    eventsfn.direction = [-1] * n_events
    return dict(eventsfn=eventsfn, num_events=n_events)
