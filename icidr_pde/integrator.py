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

import io
import sys

import numpy as np
from pde.solvers.base import SolverBase
import scipy.integrate
from scipy import sparse

from . import cvode_counters
from .colored_fd import colored_fd_jacobian

from .conservative_jacobian import ConservativeDifferenceQuotients
from .time_scale import MIN_STEP_FRACTION, fastest_time_scale
from .times import controller_dt, time_tolerance
from .validation import ParameterError, choice, nonfinite_rates, real

__all__ = ["StiffSolver", "SimulationFailed", "Engine", "ScipyEngine", "CvodeEngine", "JacobianSpec",
           "ENGINES", "METHODS", "JACOBIAN_MODES", "check_tolerances"]


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
    """Counts of a run (CVODE's from its own counters, :mod:`icidr_pde.cvode_counters`;
    None where they are not available)."""

    n_steps: int | None = 0
    n_rhs: int = 0
    n_jac: int = 0
    n_lu: int | None = 0


def check_tolerances(rtol: float, atol: float) -> tuple[float, float]:
    return (real("rtol", rtol, 1e-14, 1, low_open=False), real("atol", atol, 0))


@dataclass
class JacobianSpec:
    """How the engine gets the Jacobian: `mode` and what that mode needs.

    jac: analytic jac(t, y) (modes 'analytic', 'sparse'); sparsity: the Jacobian's pattern
    (colored finite differences 'sparse-fd', 'colored-fd'; the fixed pattern of 'sparse');
    band: (lower, upper) bandwidths of the engine's ordering ('banded-fd'); nothing for
    'krylov' (matrix-free) and 'none' (dense finite differences).
    band_jac: analytic jac_into(y, J) filling the band of a dense array in the banded
    ordering (mode 'analytic' for an engine with ``banded_analytic``, when the
    discretization offers one; then `band` is set too and `jac` is None).
    weights, anchor: the conserved quantity c . y (the mass of phi) and, per column, the row
    that absorbs the column's sum, for difference quotients that keep it conserved
    (:mod:`icidr_pde.conservative_jacobian`); None if the PDE has no quadrature weights.
    """

    mode: str
    jac: object = None
    sparsity: object = None
    band: tuple[int, int] | None = None
    band_jac: object = None
    weights: np.ndarray | None = None
    anchor: np.ndarray | None = None
    line_pattern: object = None


class Engine:
    """Protocol of an integration engine, in the style of scipy's ``OdeSolver``.

    Class attributes:
        methods: the method names the engine implements
        jacobian_modes: {method: valid Jacobian modes}; the first is the method's default

    ``Engine(method, fun, t0, y0, *, rtol, atol, max_step, first_step, jacobian, margins,
    fun_into, margins_into)`` starts an integration of y' = fun(t, y) at (t0, y0); `jacobian`
    is a :class:`JacobianSpec`, `margins(y)` (optional) returns numbers that are all positive
    while the state is valid; `fun_into(t, y, out)` and `margins_into(y, out)` (optional) are
    the same written into a given array (an engine whose callbacks hand over their output
    array uses them: no temporaries). Then:

    * ``advance(t_end, check)`` takes accepted steps until the engine has passed t_end;
      `check(y)` returns a failure reason or None for every accepted state. Returns None,
      or (t_good, y_good, reason): the last valid accepted state and why it stopped;
    * ``value_at(t)`` is the state at a t inside the last step (dense output);
    * ``counts()`` is (steps or None, Jacobian evaluations, LU decompositions or None).
    """

    methods: tuple[str, ...] = ()
    jacobian_modes: dict[str, tuple[str, ...]] = {}
    #: the engine takes an analytic Jacobian in the banded ordering (JacobianSpec.band_jac)
    banded_analytic: bool = False

    def advance(self, t_end, check):
        raise NotImplementedError

    def value_at(self, t):
        raise NotImplementedError

    def counts(self):
        raise NotImplementedError


def _dense(jac):
    def dense_jac(t, y):
        J = jac(t, y)
        return J.toarray() if hasattr(J, "toarray") else J

    return dense_jac


class ScipyEngine(Engine):
    """One scipy OdeSolver (BDF, Radau, LSODA), checked after every accepted step."""

    methods = ("BDF", "Radau", "LSODA")
    jacobian_modes = {"BDF": ("analytic", "sparse-fd", "colored-fd", "none"),
                      "Radau": ("analytic", "sparse-fd", "colored-fd", "none"),
                      "LSODA": ("banded-fd", "analytic", "none")}

    def __init__(self, method, fun, t0, y0, *, rtol, atol, max_step=np.inf, first_step=None,
                 jacobian: JacobianSpec, margins=None, fun_into=None, margins_into=None):
        options = dict(rtol=rtol, atol=atol, max_step=max_step)
        if first_step is not None:
            options["first_step"] = first_step
        if jacobian.mode == "analytic":
            options["jac"] = _dense(jacobian.jac) if method == "LSODA" else jacobian.jac  # Fortran: dense
        elif jacobian.mode == "sparse-fd" and jacobian.weights is not None:
            # colored difference quotients that keep the Newton updates conservative (scipy's
            # own drift the mass by 6e-11 with Radau, scene sine, N = 47)
            dq = ConservativeDifferenceQuotients(fun, jacobian.weights, jacobian.anchor,
                                                 floor=atol / rtol, sparsity=jacobian.sparsity)
            options["jac"] = dq.sparse
        elif jacobian.mode == "sparse-fd":
            options["jac_sparsity"] = jacobian.sparsity
        elif jacobian.mode == "colored-fd":
            options["jac"] = colored_fd_jacobian(fun, jacobian.sparsity, 1.0)
        elif jacobian.mode == "none" and jacobian.weights is not None and 8 * len(y0) ** 2 <= 2**28:
            dq = ConservativeDifferenceQuotients(fun, jacobian.weights, jacobian.anchor, floor=atol / rtol)
            options["jac"] = lambda t, y: dq.sparse(t, y).toarray()
        elif jacobian.mode == "banded-fd":
            options.update(lband=jacobian.band[0], uband=jacobian.band[1])
        self.solver = getattr(scipy.integrate, method)(fun, t0, y0, np.inf, **options)
        self.t, self.y, self.n_steps = t0, np.array(y0), 0

    def advance(self, t_end, check):
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
        return self.n_steps, int(self.solver.njev), int(self.solver.nlu)


#: refactor CVODE's dense Newton matrix when gamma = h/l0 changed by more than this (SUNDIALS: 0.3).
#: Measured, mu(I) shear t* and iCIDR sine, Chebyshev N = 201: 138 -> 100 and 130 -> 97 LU
#: decompositions, t* error against the converged t* 3.5e-5 -> 9.9e-6, max|w| error 6.4e-5 -> 5.1e-5
#: (0.6: 160 and 113 LUs; 1.5: 138 and 109)
DENSE_LU_DELTA_GAMMA = 1.0

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
    """SUNDIALS CVODE (BDF, orders 1-5) via scikit-sundae: the compiled fast path.

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
    the Newton systems matrix-free; measured on iCIDR bump2d it beats SuperLU_MT with the
    analytic Jacobian ('sparse'): 2.3 s against 72 s at 64^2 (see docs/sim2d.md).
    SUNDIALS' messages are captured into the failure reason. The minimum step is relative
    to the problem's fastest time scale (:func:`fastest_time_scale`).
    """

    methods = ("CVODE",)
    jacobian_modes = {"CVODE": ("analytic", "banded-fd", "krylov", "sparse", "none")}
    banded_analytic = True

    def __init__(self, method, fun, t0, y0, *, rtol, atol, max_step=np.inf, first_step=None,
                 jacobian: JacobianSpec, margins=None, fun_into=None, margins_into=None):
        from sksundae.cvode import CVODE

        # min_step: without one CVODE halves h down to 1e-165 before giving up on a blow-up
        # (seconds of work). It is relative to the problem's fastest time scale, as scipy's
        # spacing test is relative to t: a fixed 1e-14 stopped iCIDR at t* = 0 near jamming
        # and in tiny cells, whose time scales are 1e-14 to 1e-13.
        self.time_scale = fastest_time_scale(fun, t0, y0)
        kwargs = dict(method="BDF", rtol=rtol, atol=atol, max_num_steps=1_000_000,
                      min_step=MIN_STEP_FRACTION * self.time_scale,
                      max_step=max_step if np.isfinite(max_step) else 1e300)  # 0 ("none") < min_step
        if first_step is not None:
            kwargs["first_step"] = first_step
        n = len(y0)
        conserving = (jacobian.mode in ("banded-fd", "none") and jacobian.weights is not None
                      and 8 * n * n <= 2**28)
        if conserving:
            band = jacobian.band if jacobian.mode == "banded-fd" else None
            dq = ConservativeDifferenceQuotients(fun, jacobian.weights, jacobian.anchor, band,
                                                 floor=atol / rtol)

            def jacfn(t, y, yp, JJ):  # scikit-sundae hands a dense n x n array, even for 'band'
                dq.fill(t, y, JJ)

            kwargs["jacfn"] = jacfn
            if band is not None:
                kwargs.update(linsolver="band", lband=band[0], uband=band[1])
        elif jacobian.mode == "banded-fd":
            kwargs.update(linsolver="band", lband=jacobian.band[0], uband=jacobian.band[1])
        elif jacobian.mode == "krylov":  # GMRES, Jacobian-vector products by CVODE's difference quotients
            kwargs.update(linsolver="gmres", krylov_dim=20)
            if jacobian.line_pattern is not None:
                kwargs["precond"] = _line_preconditioner(jacobian.jac, jacobian.line_pattern, jacobian.weights,
                                                         jacobian.anchor)
        elif jacobian.mode == "sparse":  # SuperLU_MT on the fixed pattern, analytic values
            values = _pattern_values(jacobian.jac, jacobian.sparsity)

            def jacfn(t, y, yp, JJ):
                JJ[:] = values(t, np.array(y))

            kwargs.update(linsolver="sparse", sparsity=jacobian.sparsity, jacfn=jacfn)
        elif jacobian.mode == "analytic" and jacobian.band_jac is not None:
            jac_into = jacobian.band_jac

            def jacfn(t, y, yp, JJ):  # JJ: (n, n), CVODE copies its band
                jac_into(y, JJ)

            kwargs.update(linsolver="band", lband=jacobian.band[0], uband=jacobian.band[1], jacfn=jacfn)
        elif jacobian.mode == "analytic":
            dense_jac = _dense(jacobian.jac)

            def jacfn(t, y, yp, JJ):  # scikit-sundae reads this signature: no extra arguments
                JJ[:, :] = dense_jac(t, y)

            kwargs.update(linsolver="lapackdense", jacfn=jacfn)
        if margins_into is not None:  # the root function runs at every step: no temporaries
            n_events = len(margins(y0))

            def eventsfn(t, y, events):
                margins_into(y, events)

            eventsfn.terminal = [True] * n_events
            eventsfn.direction = [-1] * n_events
            kwargs.update(eventsfn=eventsfn, num_events=n_events)
        elif margins is not None:
            n_events = len(margins(y0))

            def eventsfn(t, y, events):
                events[:] = margins(y)

            eventsfn.terminal = [True] * n_events
            eventsfn.direction = [-1] * n_events
            kwargs.update(eventsfn=eventsfn, num_events=n_events)

        self.interrupt = None
        self.output = _CapturedOutput()
        self.log: list[str] = []

        if fun_into is None:
            def fun_into(t, y, yp):
                yp[:] = fun(t, y)

        def rhsfn(t, y, yp):
            try:
                fun_into(t, y, yp)
            except KeyboardInterrupt as interrupt:  # re-raised once CVODE has returned
                self.interrupt = interrupt
                raise

        self.solver = CVODE(rhsfn, **kwargs)
        start = self.solver.init_step(t0, y0)
        self.counters = cvode_counters.attach(self.solver, start.nfev)
        if jacobian.mode == "krylov" and self.counters is not None:
            self.counters.set_eps_lin(KRYLOV_EPS_LIN)
        if kwargs.get("linsolver") == "lapackdense" and self.counters is not None:
            # a dense LU (Chebyshev: 603 x 603, ~30 ms) costs tens of RHS calls: keep the factored
            # I - gamma J until gamma has doubled (modified Newton), not only changed by 30 %
            self.counters.set_lsetup_reuse(delta_gamma=DENSE_LU_DELTA_GAMMA)
        self.t, self.y, self.njev = t0, np.array(y0), 0

    def advance(self, t_end, check):
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

    def counts(self):
        if self.counters is None:
            return None, self.njev, None
        return self.counters.get("steps"), self.counters.get("jac"), self.counters.get("lu")


def _line_preconditioner(jac, pattern, weights=None, anchor=None):
    """CVODE's left preconditioner P = I - gamma J_line: the analytic Jacobian restricted to
    `pattern` (the couplings along z of a thin 2-D cell, :meth:`ShearCell2DPDE.line_pattern`),
    factored by SuperLU; J_line is re-evaluated when CVODE asks for a new Jacobian, P whenever
    gamma changes. With the mass weights c and `anchor` (:meth:`StiffSolver._conserved`) each
    column's dropped mass-row entries are added to its anchor row, so that c P = c and the
    preconditioned Newton corrections keep the mass. Without it GMRES(20) cannot solve the
    Newton systems of a thin cell: bump2d 32^2 at H = 0.01 (L = 30) failed at t = 2e-3 with
    h = 7e-9; at H = 0.3 it took 2814 steps (156 preconditioned)."""
    from scipy.sparse.linalg import splu
    from sksundae.cvode import CVODEPrecond

    keep = sparse.csc_matrix(pattern, dtype=float)
    keep.data[:] = 1.0
    n = keep.shape[0]
    eye = sparse.identity(n, format="csc")
    saved = {}

    def line_jacobian(t, y):
        J = sparse.csc_matrix(jac(t, np.array(y))).multiply(keep).tocsc()
        if weights is None:
            return J
        lost = -(weights @ J)  # the dropped part of each column's mass row sum (c J = 0)
        return (J + sparse.csc_matrix((lost / weights[anchor], (anchor, np.arange(n))), shape=(n, n))).tocsc()

    def setup(t, y, yp, jok, jnew, gamma):
        if not jok or "J" not in saved:
            saved["J"] = line_jacobian(t, y)
            jnew[0] = 1
        else:
            jnew[0] = 0
        saved["lu"] = splu((eye - gamma * saved["J"]).tocsc())

    def solve(t, y, yp, r, z, gamma, delta, lr):
        z[:] = saved["lu"].solve(np.array(r))

    return CVODEPrecond(setup, solve, side="left")


def _pattern_values(jac, pattern):
    """values(t, y): the sparse jac(t, y) in the CSC order of `pattern` (zeros where it has none)."""
    P = sparse.csc_matrix(pattern)
    P.sort_indices()
    keys = np.repeat(np.arange(P.shape[1], dtype=np.int64), np.diff(P.indptr)) * P.shape[0] + P.indices

    def values(t, y):
        J = sparse.coo_matrix(jac(t, y))
        pos = np.searchsorted(keys, J.col.astype(np.int64) * J.shape[0] + J.row)
        if np.any(pos >= keys.size) or np.any(keys[np.minimum(pos, keys.size - 1)] != J.col.astype(np.int64) * J.shape[0] + J.row):
            raise ValueError("the Jacobian has entries outside its declared sparsity pattern")
        out = np.zeros(keys.size)
        np.add.at(out, pos, J.data)
        return out

    return values


#: method name -> engine class
ENGINES = {method: engine for engine in (ScipyEngine, CvodeEngine) for method in engine.methods}
METHODS = tuple(ENGINES)
#: CVODE's Krylov tolerance factor. SUNDIALS' 0.05 is too loose for an ill-posed law: the inexact
#: Newton solves delay the grid-scale growth (mu(I) bump2d 128^2: t* 0.11844; eps_lin 5e-4: 0.11709,
#: 5e-5: 0.11700, 5e-6: 0.11697; docs/scaling.md, benchmarks/tstar2d_solvers.py)
KRYLOV_EPS_LIN = 5e-5

JACOBIAN_MODES = ("analytic", "sparse-fd", "banded-fd", "colored-fd", "krylov", "sparse", "none")


class StiffSolver(SolverBase):
    """py-pde solver wrapping stiff implicit methods with one persistent integrator.

    Use as ``eq.solve(state, t_range, solver="stiff", method="BDF", rtol=1e-6)``.

    Args:
        pde: the PDE; a discretization of :mod:`icidr_pde.discretizations` (its contract:
            ``make_rates``, ``make_jacobian``, ``jacobian_sparsity``, ``interleaving``,
            ``check_state``, ``validity_margins``) or any py-pde PDE (then only the
            right-hand side is used, through py-pde's backend)
        method: a key of :data:`ENGINES`: 'BDF' (scipy, default, like ode15s), 'Radau',
            'LSODA' (scipy) or 'CVODE' (SUNDIALS via scikit-sundae)
        rtol, atol: tolerances of the integrator
        jacobian: one of the engine's ``jacobian_modes[method]``: 'analytic',
            'sparse-fd' (scipy's colored differences, BDF/Radau), 'colored-fd' (colored
            differences with well-scaled increments, :mod:`icidr_pde.colored_fd`, BDF/Radau),
            'banded-fd' (LSODA/CVODE banded differences on the interleaved ordering),
            'krylov' (CVODE's GMRES, matrix-free), 'sparse' (CVODE's SuperLU_MT with the
            analytic Jacobian on the scheme's pattern) or 'none' (dense differences, for
            comparison only); None picks the engine's default for the method (for CVODE on a
            scheme without a banded ordering: 'krylov' if its Jacobian is sparse, else 'analytic')
        max_step: largest step the integrator may take
        backend: 'numba' (default: the discretization's compiled kernels, cached on disk) or
            'numpy' (its numpy implementation, no compilation)
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
        self.engine = ENGINES[choice("method", method, ENGINES)]
        valid = self.engine.jacobian_modes[method]
        self._default_jacobian = jacobian is None
        if jacobian is None:
            jacobian = valid[0]
        if jacobian not in valid:
            raise ParameterError(f"`jacobian` must be one of {valid} for method {method!r}; got {jacobian!r}")
        rtol, atol = check_tolerances(rtol, atol)
        max_step = real("max_step", max_step, 0) if np.isfinite(max_step) else np.inf
        self.method = method
        self.rtol = float(rtol)
        self.atol = float(atol)
        self.jacobian = jacobian
        self.max_step = max_step
        self.stats = StepStatistics()
        self.last_good: tuple[float, np.ndarray] | None = None
        self._records: list = []
        #: the time a KeyboardInterrupt stopped the run at inside a stepper call, else None
        self.interrupted: float | None = None

    def _conserved(self, state, perm):
        """(weights, anchor) of the mass of phi in the engine's ordering, or (None, None)."""
        weights = getattr(self.pde, "quadrature_weights", None)
        if weights is None:
            return None, None
        n = state.data[0].size
        c = np.zeros(state.data.size)
        c[:n] = np.ravel(weights(state.grid))
        native = np.arange(c.size) if perm is None else np.asarray(perm)
        position = np.argsort(native)
        return c[native], position[native % n]  # a column's anchor: phi at its own node

    def _mode(self, state):
        """(mode, ordering): the Jacobian mode this run takes, the defaults resolved
        ('analytic-band': the analytic Jacobian in the engine's band matrix), and the
        discretization's banded ordering (perm, lband, uband) or None. Builds nothing."""
        mode, pde = self.jacobian, self.pde
        ordering = getattr(pde, "interleaving", lambda state: None)(state)
        if mode == "analytic" and self.engine.banded_analytic and ordering is not None \
                and hasattr(pde, "make_band_jacobian"):
            return "analytic-band", ordering
        if mode == "analytic" and self._default_jacobian and self.engine.banded_analytic:
            mode = self.jacobian = "banded-fd"  # no analytic band: difference quotients, or below
        if mode == "banded-fd" and ordering is None:
            if not self._default_jacobian:
                raise ValueError("`jacobian`='banded-fd' needs a discretization with a banded "
                                 "ordering (finite differences); use 'analytic' or 'none'")
            # no banded ordering: Krylov where the Jacobian is sparse (2-D), else dense analytic (Chebyshev)
            sparse_pattern = pde.jacobian_sparsity(state) is not None
            mode = self.jacobian = "krylov" if sparse_pattern and "krylov" in self.engine.jacobian_modes[
                self.method] else "analytic"
        return mode, ordering

    def check_memory(self, state) -> None:
        """Refuse (ParameterError), before anything is allocated, a run on `state`'s grid whose
        scheme and linear algebra need more than half the memory available
        (:func:`icidr_pde.discretizations.grid_size.check_path`: a dense n x n array where this path has one)."""
        limit = getattr(self.pde, "grid_limit", None)
        if limit is None:
            return
        from .discretizations.grid_size import check_path

        shape = tuple(state.grid.shape)
        what = f"`N` = {shape[0]}" if len(shape) == 1 else "`Nx` x `Nz` = " + " x ".join(map(str, shape))
        mode, _ = self._mode(state)
        hint = ("; the native engine (without save or movie) and method 'BDF' need no dense array"
                if mode == "analytic-band" else "")
        check_path(what, state.data.size, limit.memory_estimate(int(np.prod(shape))), self.method, mode, hint)

    def _jacobian_spec(self, state):
        """The JacobianSpec of the chosen mode and the permutation into the engine's ordering."""
        pde = self.pde
        mode, ordering = self._mode(state)
        if mode == "analytic-band":
            perm, lband, uband = ordering
            return JacobianSpec("analytic", band=(lband, uband), band_jac=pde.make_band_jacobian(state)), perm
        if mode == "banded-fd":
            perm, lband, uband = ordering
            weights, anchor = self._conserved(state, perm)
            return JacobianSpec(mode, band=(lband, uband), weights=weights, anchor=anchor), perm
        if mode == "analytic":
            return JacobianSpec(mode, jac=pde.make_jacobian(state)), None
        if mode == "sparse":
            return JacobianSpec(mode, jac=pde.make_jacobian(state), sparsity=pde.jacobian_sparsity(state)), None
        if mode in ("sparse-fd", "colored-fd"):
            sparsity = pde.jacobian_sparsity(state)
            if sparsity is None:  # it would run dense differences labelled as colored ones
                raise ParameterError(f"`jacobian`={mode!r} needs a sparse Jacobian; this "
                                     "discretization's is dense: use 'analytic' or 'none'")
            weights, anchor = self._conserved(state, None) if mode == "sparse-fd" else (None, None)
            return JacobianSpec(mode, sparsity=sparsity, weights=weights, anchor=anchor), None
        weights, anchor = self._conserved(state, None)
        line = getattr(pde, "line_pattern", lambda state: None)(state) if mode == "krylov" else None
        if line is not None:  # a thin cell: GMRES preconditioned along the walls' normal
            n = state.data[0].size
            mass = np.zeros(state.data.size)
            mass[:n] = 1.0  # equal finite-volume cells: the mass is the sum of phi
            return JacobianSpec(mode, jac=pde.make_jacobian(state), line_pattern=line, weights=mass,
                                anchor=np.arange(mass.size) % n), None
        return JacobianSpec(mode, weights=weights, anchor=anchor), None

    def _rates(self, state):
        """The right-hand side: the discretization's cached kernels, else py-pde's backend."""
        if getattr(self._backend, "name", self._backend) == "numba" and hasattr(self.pde, "make_rates"):
            self.info["backend"] = "compiled kernels (icidr_pde.rheology.codegen)"
            return self.pde.make_rates(state)
        self._select_backend(state)
        return self.backend.make_pde_rhs(self.pde, state)

    def record(self, times, callback) -> None:
        """Call `callback(t, data)` with the state data at each of `times` (sorted), from inside
        the stepping loop: the integrator stops at these output times as it would at py-pde
        interrupts (the same sequence of output requests, so the same numbers), without the
        Controller's and trackers' round trip per output time. `data` is valid only
        during the call. Times before the start are given the initial state."""
        self._records.append((np.asarray(times, dtype=float), callback))

    def _validity(self, shape, perm):
        """(inside(y), margins_into(y, out)) on the engine's vector without reordering it
        (compiled, :mod:`icidr_pde.state_bounds`), or None where the discretization has no
        validity_bounds or its phi entries are not evenly spaced in the engine's ordering."""
        bounds = getattr(self.pde, "validity_bounds", None)
        if bounds is None or bounds() is None:
            return None
        from . import state_bounds

        lo, hi = (float(b) for b in bounds())
        n = int(np.prod(shape[1:]))
        phi_at = np.arange(n) if perm is None else np.argsort(perm)[:n]
        start, stride = int(phi_at[0]), int(phi_at[1] - phi_at[0]) if n > 1 else 1
        if stride <= 0 or not np.array_equal(phi_at, start + stride * np.arange(n)):
            return None

        def margins_into(y, out):
            state_bounds.margins_into(y, start, stride, n, lo, hi, out)

        def inside(y) -> bool:
            return state_bounds.inside(y, start, stride, n, lo, hi)

        probe = np.zeros(int(np.prod(shape)))
        inside(probe)  # compile or load both signatures now (scipy's y is writable, CVODE's read-only)
        probe.flags.writeable = False
        margins_into(probe, np.empty(2))
        inside(probe)
        return inside, margins_into

    def make_stepper(self, state, dt: float | None = None):
        """Return stepper(state, t_start, t_end) advancing one persistent integrator."""
        start, cpu_start = time.perf_counter(), time.process_time()
        rhs = self._rates(state)
        rhs(np.array(state.data), 0.0)  # compile or load now, so that it counts as set-up time
        spec, perm = self._jacobian_spec(state)  # a compiled Jacobian is loaded here
        pde_margins = getattr(self.pde, "validity_margins", None)
        validity = self._validity(state.data.shape, perm) if pde_margins is not None else None
        self.info["compile_s"] = time.perf_counter() - start  # wall clock, unlike py-pde's profiler
        self.info["compile_cpu_s"] = time.process_time() - cpu_start
        shape, stats = state.data.shape, self.stats
        check_state = getattr(self.pde, "check_state", lambda data: None)
        inverse = None if perm is None else np.argsort(perm)
        native = np.empty(shape)  # reused by fun_into
        native_flat = native.reshape(-1)

        def to_native(y):  # integrator ordering -> state data
            # always a fresh writable C array (CVODE passes read-only views)
            return (np.array(y, dtype=float) if perm is None else y[inverse]).reshape(shape)

        def fun(t, y):
            stats.n_rhs += 1
            rate = rhs(to_native(y), t).ravel()
            return rate if perm is None else rate[perm]

        def fun_into(t, y, out):  # the same numbers as fun, without its temporaries
            stats.n_rhs += 1
            if perm is None:
                native_flat[:] = y
                out[:] = rhs(native, t).reshape(-1)
            else:
                np.take(y, inverse, out=native_flat)
                np.take(rhs(native, t).reshape(-1), perm, out=out)

        def generic_check(y):
            return "state became non-finite" if not np.all(np.isfinite(y)) else check_state(to_native(y))

        margins = None if pde_margins is None else (lambda y: pde_margins(to_native(y)))
        margins_into, check = None, generic_check
        if validity is not None:
            inside, margins_into = validity

            def check(y):  # the message, only for a state outside
                return None if inside(y) else generic_check(y)

        self.info.update(method=self.method, rtol=self.rtol, atol=self.atol, jacobian=self.jacobian,
                         dt=None, steps=0)
        engines: list = []  # created at the first call, at its t_start
        pending = [[times, callback, 0] for times, callback in self._records]
        reached = [None, None]  # the latest time of the current call with a known state (None: state.data's)
        self.interrupted = None

        def fail(reason: str):
            if engines:
                stats.n_steps, stats.n_jac, stats.n_lu = engines[0].counts()
            t_good, y_good = self.last_good
            raise SimulationFailed(t_good, reason, to_native(y_good).copy())

        def advance(engine, t):
            failure = engine.advance(t, check)
            if failure is not None:
                self.last_good = failure[:2]
                fail(failure[2])

        def record_before(engine, t_end):
            """Advance to and record every output time before t_end (py-pde fires an
            interrupt within time_tolerance of the current time: a time that close to t_end is
            t_end's)."""
            while True:
                due = [entry[0][entry[2]] for entry in pending if entry[2] < entry[0].size]
                t = min(due, default=np.inf)
                if not t < t_end - time_tolerance(t_end):
                    return
                advance(engine, t)
                data = to_native(engine.value_at(t))
                reached[:] = [t, data]
                record_at(t, data)

        def record_at(t, data):
            close = t + time_tolerance(t)
            for entry in pending:
                times, callback, k = entry
                if k < times.size and times[k] < close:
                    callback(t, data)
                    while k < times.size and times[k] < close:
                        k += 1
                    entry[2] = k

        def run_segment(state, engine, t_end):
            if pending:
                record_before(engine, t_end)
            advance(engine, t_end)
            state.data[...] = to_native(engine.value_at(t_end))
            reached[:] = [t_end, None]
            if pending:
                record_at(t_end, state.data)

        def stepper(state, t_start: float, t_end: float) -> float:
            if self.interrupted is not None:  # stopped inside the previous call: py-pde ends here
                raise KeyboardInterrupt
            if not engines:
                for entry in pending:  # as py-pde's FixedInterrupts: earlier times are skipped
                    entry[2] = int(np.searchsorted(entry[0], t_start, side="left"))
                record_at(t_start, state.data)
                y0 = np.array(state.data, dtype=float).ravel()
                y0 = y0 if perm is None else y0[perm]
                self.last_good = (t_start, y0.copy())
                reason = check(y0)
                if reason:
                    fail(f"initial state invalid: {reason}")
                with np.errstate(all="ignore"):
                    reason = nonfinite_rates(rhs(np.array(state.data), t_start), t_start)
                if reason:
                    fail(reason)
                engines.append(self.engine(self.method, fun, t_start, y0, rtol=self.rtol, atol=self.atol,
                                           max_step=self.max_step, first_step=dt, jacobian=spec,
                                           margins=margins, fun_into=fun_into, margins_into=margins_into))
            engine = engines[0]
            reached[:] = [t_start, None]
            try:
                run_segment(state, engine, t_end)
            except KeyboardInterrupt:
                # Ctrl-C (or a recorder) inside the loop: end this call at the last time whose
                # state is known, as py-pde would have at that interrupt; raised again next call
                self.interrupted = reached[0]
                if reached[1] is not None:
                    state.data[...] = reached[1]
                return reached[0]
            finally:
                stats.n_steps, stats.n_jac, stats.n_lu = engine.counts()
                # the time windows of py-pde's Controller, resolvable at t (see controller_dt)
                self.info.update(steps=stats.n_steps, n_rhs=stats.n_rhs, dt=controller_dt(t_end))
            return t_end

        return stepper
