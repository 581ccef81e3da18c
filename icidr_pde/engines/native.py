"""The native engine: SUNDIALS CVODE on a compiled C problem (:mod:`icidr_pde.native`).

The :class:`~.base.Problem` carries the compiled problem (rates, analytic Jacobian, the bounds
of phi, CVODE's memory: ``problem.compiled``); :meth:`NativeEngine.advance_outputs` advances
CVODE through many output times in one call into C, writing max|w| at every output and the
states asked for (no Python per step). The run path (:func:`icidr_pde.api.run`) owns the
schedule of those outputs, the progress bar and the Result. numpy and ctypes only.
"""

from __future__ import annotations

import numpy as np

from ..cvode_settings import BDF_MAX_ORDER
from .base import Engine, JacobianSpec, Problem
from .linear import compiled_solver

__all__ = ["NativeEngine", "native_problem"]


def native_problem(compiled, y0, check, mode: str = "analytic") -> Problem:
    """The :class:`~.base.Problem` of the compiled problem `compiled` from the state vector `y0`,
    its accepted states checked by `check(y)` (the case's check_state); the Jacobian (`mode`:
    'analytic', or 'krylov' for matrix-free GMRES) is the compiled problem's own."""
    def fun(t, y):
        return compiled.rates(y)

    return Problem(y0=np.ascontiguousarray(y0, dtype=float), fun=fun, jacobian=JacobianSpec(mode), check=check,
                   compiled=compiled)


class NativeEngine(Engine):
    """CVODE on the compiled problem of `problem` (``problem.compiled``, a
    :class:`icidr_pde.native.NativeProblem`) from (t0, problem.y0): its smallest step
    MIN_STEP_FRACTION x the fastest time scale, as the other CVODE engine's. Accepted states are
    checked by ``problem.check``; the linear solver is the one the compiled problem set up."""

    name = "native"
    methods = ("CVODE",)

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver="", max_order=BDF_MAX_ORDER):
        compiled = problem.compiled
        if compiled is None:
            raise ValueError("the native engine integrates a Problem with a compiled problem "
                             "(icidr_pde.native); got one of Python callables only")
        kind = getattr(compiled, "linear_solver", None)  # what the compiled problem set up (Chebyshev)
        if kind is not None:
            linear_solver = compiled_solver(kind, getattr(compiled, "preconditioner", ""),
                                            getattr(compiled, "solver", "")).name
        self.problem, self.compiled = problem, compiled
        self.linear_solver = getattr(linear_solver, "name", linear_solver)  # a LinearSolver or its name
        self.t = float(t0)
        self._output: tuple[float, np.ndarray] | None = None  # the state of the last advance()
        compiled.start(problem.y0, rtol=rtol, atol=atol, t0=t0, max_step=max_step, first_step=first_step,
                       max_order=max_order)

    def advance_outputs(self, times, store, max_w, states, measure=None):
        """CVODE through `times`, max|w| into `max_w` (computed in C: `measure` is not used),
        the state of output k into states[store[k]] where store[k] >= 0. Returns (outputs done,
        failure): failure is None or (t_good, y_good, reason), the last valid state and why
        the run stopped."""
        done, status, flag = self.compiled.advance(times, store, max_w, states)
        if done:
            self.t = float(times[done - 1])
        if not status:
            return done, None
        t_good, y_good = self.compiled.last_good()
        check = self.problem.check
        if status == 1:
            reason = check(y_good) or "state reached the boundary of its valid range"
        elif status == 2:
            reason = f"integrator failed ({self.compiled.message(flag)})"
        else:
            reason = check(y_good)
        return done, (t_good, y_good, reason)

    def advance(self, t_end):
        """CVODE to t_end (one output of :meth:`advance_outputs`): None, or (t_good, y_good, reason)."""
        states = np.empty((1, self.problem.y0.size))
        done, failure = self.advance_outputs(np.array([float(t_end)]), np.zeros(1, dtype=np.intc), np.empty(1),
                                             states)
        if failure is None:
            self._output = (float(t_end), states[0])
        return failure

    def value_at(self, t):
        """The state at the time of the last :meth:`advance` (the C driver hands out the states at
        its output times, no dense output between them)."""
        t_out, y = self._output if self._output is not None else self.last_good()
        if t != t_out:
            raise ValueError(f"the native engine has the state at t = {t_out:g} (its last output), not at t = {t:g}")
        return y

    def last_good(self):
        """(t, y) of the last state CVODE returned (the driver keeps it)."""
        return self.compiled.last_good()

    def last_step(self):
        """(t, y) of CVODE's last accepted step (the compiled problem's ``last_step``) where that state
        passes the problem's check, else the last output's (:meth:`last_good`). Ctrl-C is seen
        once a call into C has returned, at most ``native.STEPS_BETWEEN_SIGNALS`` steps after the
        previous return: the step reached is then that call's last."""
        return self._checked_step(self.compiled.last_step())

    def counts(self):
        counts = self.compiled.counts()
        return counts["steps"], counts["jac"], counts["lu"]

    def n_rhs(self) -> int:
        return self.compiled.counts()["rhs"]
