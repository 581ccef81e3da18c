"""Stiff implicit time integration that keeps its state across tracker interrupts.

py-pde's stock ``scipy`` solver calls :func:`scipy.integrate.solve_ivp` afresh between
every two tracker interrupts, so BDF restarts at order 1 with a tiny step and a new
Jacobian each time. :class:`StiffSolver` instead holds one :class:`scipy.integrate.OdeSolver`
(BDF, Radau or LSODA, as MATLAB's ode15s used by the paper) for the whole run, steps it
past each interrupt and reads the state there from its dense output.

A run fails (:class:`SimulationFailed`) when the integrator cannot meet its tolerances
(step-size underflow, the paper's 'non-convergent'), when the state becomes non-finite
or when phi leaves (0, phi_c). The failure carries the last accepted time t* and state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pde.solvers.base import SolverBase
from scipy.integrate import BDF, LSODA, Radau

__all__ = ["StiffSolver", "SimulationFailed", "METHODS", "JACOBIAN_MODES"]

METHODS = {"BDF": BDF, "Radau": Radau, "LSODA": LSODA}
JACOBIAN_MODES = ("analytic", "sparse-fd", "none")


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
    n_steps: int = 0
    n_rhs: int = 0
    n_jac: int = 0
    n_lu: int = 0


def check_tolerances(rtol: float, atol: float) -> None:
    if not (np.isfinite(rtol) and 1e-14 <= rtol < 1):
        raise ValueError(f"`rtol` must lie in [1e-14, 1); got {rtol}")
    if not (np.isfinite(atol) and atol > 0):
        raise ValueError(f"`atol` must be > 0; got {atol}")


class StiffSolver(SolverBase):
    """py-pde solver wrapping scipy's stiff methods with a persistent integrator.

    Use as ``eq.solve(state, t_range, solver="stiff", method="BDF", rtol=1e-6)``.

    Args:
        pde: the PDE; it may offer ``make_jacobian(state)`` (analytic, sparse) and
            ``jacobian_sparsity(state)`` (for colored finite differences) and
            ``check_state(data)`` (returns a failure reason or None)
        method: 'BDF' (default, like ode15s), 'Radau' or 'LSODA'
        rtol, atol: tolerances of the integrator
        jacobian: 'analytic', 'sparse-fd' (scipy's colored differences on the PDE's
            sparsity pattern) or 'none' (dense differences, for comparison only)
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
        jacobian: str = "analytic",
        max_step: float = np.inf,
        backend: str = "numba",
    ):
        super().__init__(pde, backend=backend)
        if method not in METHODS:
            raise ValueError(f"`method` must be one of {sorted(METHODS)}; got {method!r}")
        if jacobian not in JACOBIAN_MODES:
            raise ValueError(f"`jacobian` must be one of {JACOBIAN_MODES}; got {jacobian!r}")
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

    def _jacobian_options(self, state) -> dict:
        if self.jacobian == "analytic":
            return {"jac": self.pde.make_jacobian(state)}
        if self.jacobian == "sparse-fd":
            if self.method == "LSODA":
                raise ValueError("`jacobian`='sparse-fd' is not supported by LSODA; "
                                 "use 'analytic' or 'none'")
            return {"jac_sparsity": self.pde.jacobian_sparsity(state)}
        return {}

    def make_stepper(self, state, dt: float | None = None):
        """Return stepper(state, t_start, t_end) advancing one persistent integrator."""
        self._select_backend(state)
        rhs = self.backend.make_pde_rhs(self.pde, state)
        shape = state.data.shape
        rhs(np.array(state.data), 0.0)  # compile now, so that it counts as set-up time
        stats = self.stats
        check_state = getattr(self.pde, "check_state", lambda data: None)

        def fun(t, y):
            stats.n_rhs += 1
            return rhs(y.reshape(shape), t).ravel()

        options = dict(rtol=self.rtol, atol=self.atol, max_step=self.max_step)
        if dt is not None:
            options["first_step"] = dt
        options.update(self._jacobian_options(state))
        self.info.update(method=self.method, rtol=self.rtol, atol=self.atol,
                         jacobian=self.jacobian, dt=None, steps=0)
        integrator: list = []  # created lazily at the first call, at its t_start

        def fail(reason: str):
            if integrator:
                stats.n_jac, stats.n_lu = integrator[0].njev, integrator[0].nlu
            t_good, y_good = self.last_good
            raise SimulationFailed(t_good, reason, y_good.reshape(shape).copy())

        def stepper(state, t_start: float, t_end: float) -> float:
            if not integrator:
                y0 = np.array(state.data, dtype=float).ravel()
                reason = check_state(y0.reshape(shape))
                self.last_good = (t_start, y0.copy())
                if reason:
                    fail(f"initial state invalid: {reason}")
                integrator.append(METHODS[self.method](fun, t_start, y0, np.inf, **options))
            solver = integrator[0]
            while solver.t < t_end:
                message = solver.step()
                if solver.status == "failed":
                    fail(f"integrator failed ({message})")
                if not np.all(np.isfinite(solver.y)):
                    fail("state became non-finite")
                reason = check_state(solver.y.reshape(shape))
                if reason:
                    fail(reason)
                stats.n_steps += 1
                self.last_good = (solver.t, solver.y.copy())
            if solver.t == t_end:
                y = solver.y
            else:
                y = solver.dense_output()(t_end)
            state.data[...] = y.reshape(shape)
            self.info.update(steps=stats.n_steps, n_rhs=stats.n_rhs)
            stats.n_jac, stats.n_lu = solver.njev, solver.nlu
            return t_end

        return stepper
