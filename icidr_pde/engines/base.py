"""The contracts of the engines: :class:`Problem` (what is integrated) and :class:`Engine`
(what integrates it), with :class:`JacobianSpec`, :class:`StepStatistics` and
:class:`SimulationFailed`.

numpy only: the run path and :func:`~icidr_pde.engines.choose.choose` import this module on
a warm native run, which loads neither py-pde, numba, scipy, sympy nor scikit-sundae.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..cvode_settings import BDF_MAX_ORDER, DENSE_LU_DELTA_GAMMA, KRYLOV_DIM, KRYLOV_EPS_LIN  # of both CVODE engines
from ..time_scale import fastest_time_scale
from ..validation import real

__all__ = ["SimulationFailed", "StepStatistics", "JacobianSpec", "Problem", "Engine", "check_tolerances",
           "DENSE_LU_DELTA_GAMMA", "KRYLOV_EPS_LIN",
           "KRYLOV_DIM"]

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
    """Counts of a run (CVODE's from its own counters, :mod:`icidr_pde.engines.cvode_counters`;
    None where they are not available)."""

    n_steps: int | None = 0
    n_rhs: int = 0
    n_jac: int = 0
    n_lu: int | None = 0


def check_tolerances(rtol: float, atol: float) -> tuple[float, float]:
    """(rtol, atol) as floats, or a ParameterError naming the one out of range."""
    return (real("rtol", rtol, 1e-14, 1, low_open=False), real("atol", atol, 0))


@dataclass
class JacobianSpec:
    """How the engine gets the Jacobian: `mode` and what that mode needs.

    jac: analytic jac(t, y) (modes 'analytic', 'sparse', 'amg'); sparsity: the Jacobian's pattern
    (colored finite differences 'sparse-fd', 'colored-fd'; the fixed pattern of 'sparse');
    band: (lower, upper) bandwidths of the engine's ordering ('banded-fd'); nothing for
    'krylov' (matrix-free) and 'none' (dense finite differences).
    band_jac: analytic jac_into(y, J) filling the band of a dense array in the banded
    ordering (mode 'analytic' on an engine with a band solver, when the discretization
    offers one; then `band` is set too and `jac` is None).
    weights, anchor: the conserved quantity c . y (the mass of phi) and, per column, the row
    that absorbs the column's sum, for difference quotients that keep it conserved
    (:mod:`icidr_pde.engines.conservative_jacobian`); None if the scheme has no quadrature weights.
    line_pattern: the couplings along z of a thin 2-D cell, for GMRES's line preconditioner.
    fields: the unknowns per cell of 'amg' (the blocks of its nodal aggregation; the unknowns are
    field-major), with `jac` the analytic sparse Jacobian its hierarchy is built from.
    shape: (fields, Nx, Nz) of the unknowns of 'fourier' (field-major, x periodic), with `jac` the
    analytic sparse Jacobian whose x-average it inverts, or `x_average`: x_average(t, y) -> that
    average (:class:`icidr_pde.engines.linear.x_average.XAverage`, by blocks of x-columns: the
    whole Jacobian is never held) and `jac` None.
    """

    mode: str
    jac: object = None
    sparsity: object = None
    band: tuple[int, int] | None = None
    band_jac: object = None
    weights: np.ndarray | None = None
    anchor: np.ndarray | None = None
    line_pattern: object = None
    fields: int | None = None
    shape: tuple[int, int, int] | None = None
    x_average: object = None


@dataclass
class Problem:
    """What an engine integrates: y' = fun(t, y) from y0, in the engine's ordering of the
    unknowns, without py-pde and without knowing the scheme or the case.

    Attributes:
        y0: the initial vector (a copy the engine may keep)
        fun: fun(t, y) -> y' (a new array)
        fun_into: fun_into(t, y, out), the same numbers written into `out` (no temporaries);
            None: the engine wraps `fun`
        jacobian: the Jacobian form this run takes (:class:`JacobianSpec`), one of those the
            scheme offers: analytic dense, sparse pattern and values, banded ordering and
            band_jac, line-preconditioner pattern, or difference quotients
        check: check(y) -> why the accepted state y is invalid (non-finite, phi outside its
            range: the scheme's check_state), or None
        margins: margins(y) -> numbers all positive while lo < phi < hi (the validity bounds
            of phi in the engine vector), for an engine's root finding; None: no bounds
        margins_into: margins_into(y, out), the same into `out`; None: the engine wraps `margins`
        patches: the right-hand side on blocks of a structured grid with one ghost layer
            (:class:`~icidr_pde.cells.plane2d.pde.Patches`), for an engine that
            distributes the grid (PETSc's DMDA); None: the scheme offers none or the engine's
            ordering is permuted
        compiled: the compiled problem (:class:`icidr_pde.native.NativeProblem`: rates, Jacobian,
            bounds and CVODE's memory in C) whose handle the native engine integrates; None: a
            problem of Python callables only
    """

    y0: np.ndarray
    fun: Callable
    jacobian: JacobianSpec
    check: Callable
    fun_into: Callable | None = None
    margins: Callable | None = None
    margins_into: Callable | None = None
    patches: object = None
    compiled: object = None

    def time_scale(self, t0: float) -> float:
        """The fastest time scale 1/rho(J) at (t0, y0) (:func:`~.time_scale.fastest_time_scale`)."""
        return fastest_time_scale(self.fun, t0, self.y0)


class Engine(ABC):
    """The contract of an integration engine, in the style of scipy's ``OdeSolver``.

    Class attributes:
        name: the engine's key in :data:`icidr_pde.engines.ENGINES` (named in a run's settings)
        methods: the method names the engine implements

    State every engine keeps (set by its constructor):
        problem: the :class:`Problem` it integrates
        t: the time of its last accepted step
        linear_solver: the solver of its Newton systems as it set it up ('band LU', 'GMRES', ...)
        ran: the method it integrates with, where that is not the method it was given (PETSc's
            TS type: 'PETSC-BDF'), else None
        ranks: the number of MPI processes that compute it (1 but for PETSc under mpiexec)

    ``Engine(method, problem, t0, *, rtol, atol, max_step, first_step, linear_solver, max_order)``
    starts an integration of the :class:`Problem` at (t0, problem.y0), a BDF method taking orders
    up to `max_order` (:func:`~icidr_pde.engines.choose.time_order`; an engine whose method has no
    such knob ignores it, and the choice warns where that is known to amplify). Then:

    * ``advance(t_end)`` takes accepted steps until the engine has passed t_end (or reached
      it); every accepted state is checked by ``problem.check``. Returns None, or
      (t_good, y_good, reason): the last valid accepted state and why it stopped;
    * ``value_at(t)`` is the state at a t inside the last step (dense output);
    * ``counts()`` is (steps or None, Jacobian evaluations, LU decompositions or None);
    * ``advance_outputs(times, store, max_w, states, measure)`` advances through the output
      `times`, writing measure(y) (max|w|) into max_w[k] and the state into states[store[k]]
      where store[k] >= 0; returns (outputs done, None or the failure (t_good, y_good, reason)).
      Here by :meth:`advance` and :meth:`value_at`. It is the call the run path's drive loop
      makes (:func:`icidr_pde.drive.drive`), so that an engine may offer a faster one: the native
      engine advances through many outputs in one call into C, PETSc reduces max|w| over its ranks;
    * ``last_good()`` is (t, y) of the last output reached (the initial state before any);
    * ``last_step()`` is (t, y) of the last accepted step, at or past the last output: the time
      and state an interrupted run reached (:func:`icidr_pde.drive.outcome`), with
      ``last_step_time()`` its time alone (no state gathered over ranks).

    After the first step the step sequence does not depend on the times asked of ``advance``:
    both scipy's solvers and CVODE step past and interpolate. The first time asked does bound
    CVODE's first step (its estimate of the initial step is limited by the distance to it), so
    two runs compared step for step ask the same first output time (the same series).
    """

    name: str = ""
    methods: tuple[str, ...] = ()
    problem: Problem
    t: float
    linear_solver: str = ""
    ran: str | None = None
    ranks: int = 1

    @abstractmethod
    def __init__(self, method: str, problem: Problem, t0: float, *, rtol: float, atol: float,
                 max_step: float = np.inf, first_step: float | None = None, linear_solver: str = "",
                 max_order: int = BDF_MAX_ORDER):
        """Start integrating `problem` with `method` at (t0, problem.y0)."""

    @abstractmethod
    def advance(self, t_end) -> tuple[float, np.ndarray, str] | None:
        """Accepted steps until t_end is passed or reached; None, or (t_good, y_good, reason)."""

    @abstractmethod
    def value_at(self, t) -> np.ndarray:
        """The state at a t inside the last step."""

    @abstractmethod
    def counts(self) -> tuple[int | None, int, int | None]:
        """(steps or None, Jacobian evaluations, LU decompositions or None)."""

    def advance_outputs(self, times, store, max_w, states, measure):
        if not hasattr(self, "_last_output"):
            self._last_output = (self.t, np.array(self.y))
        for k, t in enumerate(times):
            failure = self.advance(t)
            if failure is not None:
                return k, failure
            y = self.value_at(t)
            max_w[k] = measure(y)
            if store[k] >= 0:
                states[store[k]] = y
            self._last_output = (float(t), np.array(y))
        return len(times), None

    def last_good(self):
        return getattr(self, "_last_output", (self.t, self.y))

    def last_step(self):
        """(t, y) of the last accepted step. This default, for an engine that cannot give the state
        of its steps, is the last output's (:meth:`last_good`)."""
        return self.last_good()

    def last_step_time(self) -> float:
        """The time of :meth:`last_step`."""
        return float(self.last_step()[0])

    def _checked_step(self, step):
        """`step` (t, y), a state of the integrator's own, where the problem's check passes it; else
        (None, or a state the check refuses: an interrupt between the step and its check) the last
        output's (:meth:`last_good`)."""
        if step is None or self.problem.check(step[1]) is not None:
            return self.last_good()
        return step


def dense(jac):
    """jac(t, y) as a dense array (a sparse one's toarray())."""
    def dense_jac(t, y):
        J = jac(t, y)
        return J.toarray() if hasattr(J, "toarray") else J

    return dense_jac
