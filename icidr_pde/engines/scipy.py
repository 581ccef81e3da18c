"""scipy's stiff solvers (BDF, Radau, LSODA) behind the :class:`~.base.Engine` protocol."""

from __future__ import annotations

import numpy as np
import scipy.integrate

from ..cvode_settings import BDF_MAX_ORDER
from .base import Engine, Problem, dense
from .colored_fd import colored_fd_jacobian
from .conservative_jacobian import ConservativeDifferenceQuotients

__all__ = ["ScipyEngine"]


class ScipyEngine(Engine):
    """One scipy OdeSolver (BDF, Radau, LSODA), checked after every accepted step."""

    name = "scipy"
    methods = ("BDF", "Radau", "LSODA")

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver="", max_order=BDF_MAX_ORDER):  # scipy's BDF and LSODA have no order cap: choose warns
        options = dict(rtol=rtol, atol=atol, max_step=max_step)
        if first_step is not None:
            options["first_step"] = first_step
        options.update(_jacobian_options(method, problem, rtol, atol))
        self.problem, self.linear_solver = problem, getattr(linear_solver, "name", linear_solver)  # a LinearSolver or its name
        y0 = problem.y0
        self.solver = getattr(scipy.integrate, method)(problem.fun, t0, y0, np.inf, **options)
        self.t, self.y, self.n_steps = t0, np.array(y0), 0

    def advance(self, t_end):
        solver, check = self.solver, self.problem.check
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
        return self.n_steps, int(self.solver.njev), int(self.solver.nlu)

    def last_step(self):
        """(t, y) of the last accepted step that passed the problem's check (scipy's solver may be
        one step further, with a state the check refused or not yet checked)."""
        return self.t, self.y

    def last_step_time(self) -> float:
        return float(self.t)


def _jacobian_options(method, problem: Problem, rtol, atol) -> dict:
    """scipy's Jacobian options for the problem's JacobianSpec."""
    jacobian, fun, n = problem.jacobian, problem.fun, len(problem.y0)
    if jacobian.mode == "analytic":
        return {"jac": dense(jacobian.jac) if method == "LSODA" else jacobian.jac}  # Fortran: dense
    if jacobian.mode == "sparse-fd" and jacobian.weights is not None:
        # colored difference quotients that keep the Newton updates conservative (scipy's
        # own drift the mass by 6e-11 with Radau, scene sine, N = 47)
        dq = ConservativeDifferenceQuotients(fun, jacobian.weights, jacobian.anchor,
                                             floor=atol / rtol, sparsity=jacobian.sparsity)
        return {"jac": dq.sparse}
    if jacobian.mode == "sparse-fd":
        return {"jac_sparsity": jacobian.sparsity}
    if jacobian.mode == "colored-fd":
        return {"jac": colored_fd_jacobian(fun, jacobian.sparsity, 1.0)}
    if jacobian.mode == "none" and jacobian.weights is not None and 8 * n ** 2 <= 2**28:
        dq = ConservativeDifferenceQuotients(fun, jacobian.weights, jacobian.anchor, floor=atol / rtol)
        return {"jac": lambda t, y: dq.sparse(t, y).toarray()}
    if jacobian.mode == "banded-fd":
        return {"lband": jacobian.band[0], "uband": jacobian.band[1]}
    return {}
