"""The native engine: SUNDIALS CVODE on a compiled C problem (:mod:`icidr_pde.native`).

The problem (rates, analytic Jacobian, the bounds of phi, CVODE's memory) is compiled C;
:meth:`NativeEngine.advance_outputs` advances CVODE through many output times in one call
into C, writing max|w| at every output and the states asked for (no Python per step). The
run path (:func:`icidr_pde.api.run`) owns the schedule of those outputs, the progress bar and
the Result. numpy and ctypes only.
"""

from __future__ import annotations


from ..cvode_settings import BDF_MAX_ORDER
from .base import Engine
from .linear import compiled_solver

__all__ = ["NativeEngine"]


class NativeEngine(Engine):
    """CVODE on the compiled `problem` (a :class:`icidr_pde.native.NativeProblem`) from
    (t0, y0): its smallest step MIN_STEP_FRACTION x the fastest time scale, as the other
    CVODE engine's. `check(y)` says why a state is invalid (the case's check_state)."""

    name = "native"
    methods = ("CVODE",)

    def __init__(self, method, problem, t0, y0, *, rtol, atol, check, linear_solver="", max_order=BDF_MAX_ORDER):
        kind = getattr(problem, "linear_solver", None)  # what the compiled problem set up (Chebyshev)
        if kind is not None:
            linear_solver = compiled_solver(kind, getattr(problem, "preconditioner", ""),
                                            getattr(problem, "solver", "")).name
        self.problem, self.check, self.linear_solver = problem, check, linear_solver
        problem.start(y0, rtol=rtol, atol=atol, t0=t0, max_order=max_order)

    def advance_outputs(self, times, store, max_w, states, measure=None):
        """CVODE through `times`, max|w| into `max_w` (computed in C: `measure` is not used),
        the state of output k into states[store[k]] where store[k] >= 0. Returns (outputs done,
        failure): failure is None or (t_good, y_good, reason), the last valid state and why
        the run stopped."""
        done, status, flag = self.problem.advance(times, store, max_w, states)
        if not status:
            return done, None
        t_good, y_good = self.problem.last_good()
        if status == 1:
            reason = self.check(y_good) or "state reached the boundary of its valid range"
        elif status == 2:
            reason = f"integrator failed ({self.problem.message(flag)})"
        else:
            reason = self.check(y_good)
        return done, (t_good, y_good, reason)

    def last_good(self):
        """(t, y) of the last state CVODE returned (the driver keeps it)."""
        return self.problem.last_good()

    def counts(self):
        counts = self.problem.counts()
        return counts["steps"], counts["jac"], counts["lu"]

    def n_rhs(self) -> int:
        return self.problem.counts()["rhs"]
