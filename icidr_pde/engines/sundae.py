"""SUNDIALS CVODE through scikit-sundae behind the :class:`~.base.Engine` protocol: its linear
solvers (band LU, LAPACK's dense LU, GMRES with a line or an algebraic-multigrid preconditioner,
SuperLU_MT), SUNDIALS' messages captured into the failure reason, CVODE's own counters (:mod:`.cvode_counters`)."""

from __future__ import annotations

import io
import sys

import numpy as np
from scipy import sparse

from . import cvode_counters
from .base import DENSE_LU_DELTA_GAMMA, KRYLOV_DIM, KRYLOV_EPS_LIN, Engine, Problem, dense  # KRYLOV_EPS_LIN: its engine's setting
from .choose import AMG_SOLVER, FOURIER_SOLVER
from .conservative_jacobian import ConservativeDifferenceQuotients
from ..cvode_settings import BDF_MAX_ORDER
from ..time_scale import MIN_STEP_FRACTION

__all__ = ["CvodeEngine", "KRYLOV_EPS_LIN", "LINEAR_SOLVERS"]

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
    the Newton systems matrix-free; measured on iCIDR bump2d it beats SuperLU_MT with the
    analytic Jacobian ('sparse'): 2.3 s against 72 s at 64^2 (see docs/sim2d.md); 'amg'
    preconditions that GMRES by one algebraic-multigrid V-cycle (:mod:`.amg`), 'fourier' by the
    exact inverse of the x-averaged Jacobian's Newton matrix (:mod:`.xfourier`).
    SUNDIALS' messages are captured into the failure reason. The minimum step is relative
    to the problem's fastest time scale (:func:`fastest_time_scale`).
    """

    name = "sundae"
    methods = ("CVODE",)

    def __init__(self, method, problem: Problem, t0, *, rtol, atol, max_step=np.inf, first_step=None,
                 linear_solver="dense LU", max_order=BDF_MAX_ORDER):
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
        kwargs.update(LINEAR_SOLVERS[linear_solver](problem, rtol, atol))
        kwargs.update(_events(problem))
        self.problem = problem
        if linear_solver.startswith("GMRES (line"):  # what it is on this cell
            linear_solver = "GMRES + line preconditioner" if "precond" in kwargs else "GMRES"
        self.linear_solver = linear_solver
        self.interrupt = None
        self.output = _CapturedOutput()
        self.log: list[str] = []
        self.solver = CVODE(self._rhsfn(problem), **kwargs)
        start = self.solver.init_step(t0, problem.y0)
        self.counters = cvode_counters.attach(self.solver, start.nfev)
        if problem.jacobian.mode in ("krylov", "amg", "fourier") and self.counters is not None:
            self.counters.set_eps_lin(KRYLOV_EPS_LIN)
        if kwargs.get("linsolver") == "lapackdense" and self.counters is not None:
            # a dense LU (Chebyshev: 603 x 603, ~30 ms) costs tens of RHS calls: keep the factored
            # I - gamma J until gamma has doubled (modified Newton), not only changed by 30 %
            self.counters.set_lsetup_reuse(delta_gamma=DENSE_LU_DELTA_GAMMA)
        self.t, self.y, self.njev = t0, np.array(problem.y0), 0

    def _rhsfn(self, problem):
        fun_into = _into(problem)

        def rhsfn(t, y, yp):
            try:
                fun_into(t, y, yp)
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

    def counts(self):
        if self.counters is None:
            return None, self.njev, None
        return self.counters.get("steps"), self.counters.get("jac"), self.counters.get("lu")


def _conserving_quotients(problem, band, rtol, atol):
    """Difference quotients with exact mass-row column sums (:mod:`.conservative_jacobian`) as
    scikit-sundae's jacfn, or None where the scheme has no weights or the dense hand-over array
    would pass 256 MiB (then SUNDIALS' own quotients)."""
    jacobian, n = problem.jacobian, len(problem.y0)
    if jacobian.weights is None or 8 * n * n > 2**28:
        return None
    dq = ConservativeDifferenceQuotients(problem.fun, jacobian.weights, jacobian.anchor, band, floor=atol / rtol)

    def jacfn(t, y, yp, JJ):  # scikit-sundae hands a dense n x n array, even for 'band'
        dq.fill(t, y, JJ)

    return jacfn


def _band_lu(problem, rtol, atol):
    """CVODE's band LU: the analytic band Jacobian where the scheme has one, else difference quotients."""
    jacobian = problem.jacobian
    kwargs = dict(linsolver="band", lband=jacobian.band[0], uband=jacobian.band[1])
    if jacobian.band_jac is not None:
        jac_into = jacobian.band_jac

        def jacfn(t, y, yp, JJ):  # JJ: (n, n), CVODE copies its band
            jac_into(y, JJ)

        kwargs["jacfn"] = jacfn
    else:
        jacfn = _conserving_quotients(problem, jacobian.band, rtol, atol)
        if jacfn is not None:
            kwargs["jacfn"] = jacfn
    return kwargs


def _dense_lapack(problem, rtol, atol):
    """LAPACK's dense LU on the analytic Jacobian."""
    dense_jac = dense(problem.jacobian.jac)

    def jacfn(t, y, yp, JJ):  # scikit-sundae reads this signature: no extra arguments
        JJ[:, :] = dense_jac(t, y)

    return dict(linsolver="lapackdense", jacfn=jacfn)


def _dense_quotients(problem, rtol, atol):
    """SUNDIALS' dense LU on difference quotients (for comparison only)."""
    jacfn = _conserving_quotients(problem, None, rtol, atol)
    return {} if jacfn is None else dict(jacfn=jacfn)


def _gmres(problem, rtol, atol):
    """GMRES, Jacobian-vector products by CVODE's difference quotients; preconditioned along
    the walls' normal where the scheme gives a line pattern (a thin cell)."""
    jacobian = problem.jacobian
    kwargs = dict(linsolver="gmres", krylov_dim=KRYLOV_DIM)
    if jacobian.line_pattern is not None:
        kwargs["precond"] = _line_preconditioner(jacobian.jac, jacobian.line_pattern, jacobian.weights,
                                                 jacobian.anchor)
    return kwargs


def _gmres_amg(problem, rtol, atol):
    """GMRES, Jacobian-vector products by CVODE's difference quotients, left-preconditioned by one
    algebraic-multigrid V-cycle on I - gamma J of the analytic sparse Jacobian (:mod:`.amg`)."""
    from .linear.amg_hierarchy import amg_preconditioner

    jacobian = problem.jacobian
    return dict(linsolver="gmres", krylov_dim=KRYLOV_DIM,
                precond=amg_preconditioner(jacobian.jac, jacobian.fields, jacobian.weights))


def _gmres_fourier(problem, rtol, atol):
    """GMRES, Jacobian-vector products by difference quotients with a small increment
    (:mod:`.jacobian_vector`), left-preconditioned by the inverse of I - gamma A, A the x-average
    of the analytic sparse Jacobian (:mod:`.xfourier`)."""
    from .jacobian_vector import difference_jtimes
    from .linear.xfourier_inverse import xfourier_preconditioner

    jacobian = problem.jacobian
    return dict(linsolver="gmres", krylov_dim=KRYLOV_DIM,
                precond=xfourier_preconditioner(jacobian.jac, jacobian.shape, jacobian.weights),
                jactimes=difference_jtimes(_into(problem), len(problem.y0)))


def _into(problem):
    """fun_into(t, y, out) of `problem` (wrapping its `fun` where it has none)."""
    if problem.fun_into is not None:
        return problem.fun_into
    fun = problem.fun

    def fun_into(t, y, out):
        out[:] = fun(t, y)

    return fun_into


def _superlu(problem, rtol, atol):
    """SuperLU_MT on the fixed pattern, analytic values."""
    values = _pattern_values(problem.jacobian.jac, problem.jacobian.sparsity)

    def jacfn(t, y, yp, JJ):
        JJ[:] = values(t, np.array(y))

    return dict(linsolver="sparse", sparsity=problem.jacobian.sparsity, jacfn=jacfn)


#: linear solver named by :func:`icidr_pde.engines.choose.choose` -> scikit-sundae's options
LINEAR_SOLVERS = {"band LU": _band_lu, "dense LU (LAPACK)": _dense_lapack, "dense LU": _dense_quotients,
                  "GMRES": _gmres, "GMRES (line preconditioner in thin cells)": _gmres, AMG_SOLVER: _gmres_amg,
                  FOURIER_SOLVER: _gmres_fourier,
                  "SuperLU_MT": _superlu}


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


def _line_preconditioner(jac, pattern, weights=None, anchor=None):
    """CVODE's left preconditioner P = I - gamma J_line: the analytic Jacobian restricted to
    `pattern` (the couplings along z of a thin 2-D cell, :meth:`ShearCell2DPDE.line_pattern`),
    factored by SuperLU; J_line is re-evaluated when CVODE asks for a new Jacobian, P whenever
    gamma changes. With the mass weights c and `anchor` (:meth:`StiffSolver._conserved`) each
    column's dropped mass-row entries are added to its anchor row, so that c P = c and the
    preconditioned Newton corrections keep the mass. Without it GMRES(20) cannot solve the
    Newton systems of a thin cell: bump2d 32^2 at H = 0.01 (L = 30) failed at t = 2e-3 with
    h = 7e-9; at H = 0.3 it took 2814 steps (156 preconditioned). What it holds and what its set-up
    allocates is in the memory check of the run
    (:data:`icidr_pde.discretizations.grid_size.LINE_BYTES`)."""
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
