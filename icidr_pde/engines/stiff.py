"""py-pde's solver "stiff": one persistent engine across py-pde's tracker interrupts.

py-pde's stock ``scipy`` solver calls :func:`scipy.integrate.solve_ivp` afresh between
every two tracker interrupts, so BDF restarts at order 1 with a tiny step and a new
Jacobian each time. :class:`StiffSolver` instead holds one engine for the whole run
(scipy's BDF, Radau or LSODA -- BDF being the analogue of MATLAB's ode15s used by the
paper -- or SUNDIALS CVODE), steps it past each interrupt and reads the state there from its
dense output. It adapts a py-pde scheme to the :class:`~.base.Problem` of the engines: the
scheme's rates in the engine's ordering, the Jacobian form :func:`~.choose.choose` picked,
the conserved mass, the validity bounds of phi.

A run fails (:class:`~.base.SimulationFailed`) when the integrator cannot meet its tolerances
(step-size underflow, the paper's 'non-convergent'), when the state becomes non-finite
or when phi leaves (0, phi_c). The failure carries the last accepted time t* and state.
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np
from pde.solvers.base import SolverBase

from ..validation import ParameterError, choice as checked_choice, invalid_state, nonfinite_rates, real
from . import ENGINES, METHODS, engine_class
from .base import JacobianSpec, Problem, SimulationFailed, StepStatistics, check_tolerances
from .choose import Choice, JacobianStructure, choose
from .linear import jacobian_modes, named
from .linear.base import cell_mass
from .linear.gmres import Preconditioned

__all__ = ["StiffSolver"]


class StiffSolver(SolverBase):
    """py-pde solver wrapping stiff implicit methods with one persistent integrator.

    Use as ``eq.solve(state, t_range, solver="stiff", method="BDF", rtol=1e-6)``.

    Args:
        pde: the PDE; a discretization of :mod:`icidr_pde.discretizations` (its contract:
            ``make_rates``, ``make_jacobian``, ``jacobian_sparsity``, ``interleaving``,
            ``check_state``, ``validity_margins``) or any py-pde PDE (then only the
            right-hand side is used, through py-pde's backend)
        method: one of :data:`~icidr_pde.engines.METHODS`: 'BDF' (scipy, default, like ode15s),
            'Radau', 'LSODA' (scipy) or 'CVODE' (SUNDIALS via scikit-sundae)
        rtol, atol: tolerances of the integrator
        jacobian: one of the engine's Jacobian modes for the method: 'analytic',
            'sparse-fd' (scipy's colored differences, BDF/Radau), 'colored-fd' (colored
            differences with well-scaled increments, :mod:`icidr_pde.engines.colored_fd`, BDF/Radau),
            'banded-fd' (LSODA/CVODE banded differences on the interleaved ordering),
            'krylov' (CVODE's GMRES, matrix-free), 'amg' (the same GMRES preconditioned by
            algebraic multigrid on the analytic sparse Jacobian, 2-D), 'fourier' (preconditioned by
            the inverse of the x-averaged Jacobian's Newton matrix, x-periodic 2-D), 'sparse' (CVODE's SuperLU_MT with the
            analytic Jacobian on the scheme's pattern) or 'none' (dense differences, for
            comparison only); None picks the method's best on the scheme
            (:func:`~icidr_pde.engines.choose.choose`)
        max_step: largest step the integrator may take
        backend: 'numba' (default: the discretization's compiled kernels, cached on disk) or
            'numpy' (its numpy implementation, no compilation)
        choice: the run path's :class:`~icidr_pde.engines.choose.Choice` (its settings already
            validated); None: chosen here on the first state
    """

    name = "stiff"

    def __init__(self, pde, *, method: str = "BDF", rtol: float = 1e-6, atol: float = 1e-9,
                 jacobian: str | None = None, max_step: float = np.inf, backend: str = "numba",
                 choice: Choice | None = None):
        super().__init__(pde, backend=backend)
        if choice is None:  # the py-pde idiom: checked here, as the run path checks its own
            checked_choice("method", method, METHODS)
            valid = jacobian_modes(method) or next(e.jacobian_modes[method] for e in ENGINES.values()
                                                   if method in e.methods)  # PETSc's, not a registered solver's
            if jacobian is not None and jacobian not in valid:
                raise ParameterError(f"`jacobian` must be one of {valid} for method {method!r}; got {jacobian!r}")
            rtol, atol = check_tolerances(rtol, atol)
        max_step = real("max_step", max_step, 0) if np.isfinite(max_step) else np.inf
        self.method = method
        self.rtol = float(rtol)
        self.atol = float(atol)
        self._asked = jacobian
        self.choice = choice
        self.max_step = max_step
        self.stats = StepStatistics()
        self.patches = None  # the scheme on blocks of its grid, for PETSc (make_stepper)
        self.last_good: tuple[float, np.ndarray] | None = None
        #: the time a KeyboardInterrupt stopped the run at inside a stepper call, else None
        self.interrupted: float | None = None

    @property
    def jacobian(self) -> str | None:
        """The Jacobian mode of the run (the one asked for until it is chosen)."""
        return self._asked if self.choice is None else self.choice.jacobian

    def _choose(self, state) -> Choice:
        if self.choice is None:
            thin = getattr(self.pde, "line_pattern", lambda state: None)(state) is not None
            cells = int(np.prod(state.data.shape[1:]))  # fields first: the grid's points or cells
            self.choice = choose(method=self.method, jacobian=self._asked, request="pde",
                                 structure=JacobianStructure.of(self.pde, state), thin_cell=thin, cells=cells)
            if self.choice.warning:  # as run() says it: py-pde's solve() is the other way in
                warnings.warn(self.choice.warning, RuntimeWarning, stacklevel=3)
        return self.choice

    def check_memory(self, state) -> None:
        """Refuse (ParameterError), before anything is allocated, a run on `state`'s grid whose
        scheme and linear algebra need more than half the memory available."""
        check_memory(self.pde, state.grid, self.method, self._choose(state))

    def rates(self, state):
        """The right-hand side: the discretization's cached kernels, else py-pde's backend."""
        if getattr(self._backend, "name", self._backend) == "numba" and hasattr(self.pde, "make_rates"):
            self.info["backend"] = "compiled kernels (icidr_pde.rheology.codegen)"
            return self.pde.make_rates(state)
        self._select_backend(state)
        return self.backend.make_pde_rhs(self.pde, state)


    def make_stepper(self, state, dt: float | None = None):
        """Return stepper(state, t_start, t_end) advancing one persistent integrator."""
        start, cpu_start = time.perf_counter(), time.process_time()
        rhs = self.rates(state)
        rhs(np.array(state.data), 0.0)  # compile or load now, so that it counts as set-up time
        choice = self._choose(state)
        spec, perm = jacobian_spec(self.pde, state, choice)  # a compiled Jacobian is loaded here
        ordering = Ordering(rhs, state.data.shape, perm, self.stats)
        validity = _validity(self.pde, state.data.shape, perm)
        self.patches = scheme_patches(self.pde, state, choice, perm)
        self.info["compile_s"] = time.perf_counter() - start  # wall clock, unlike py-pde's profiler
        self.info["compile_cpu_s"] = time.process_time() - cpu_start
        self.info.update(method=self.method, rtol=self.rtol, atol=self.atol, jacobian=self.jacobian,
                         linear_solver=choice.linear_solver, dt=None, steps=0)
        self.interrupted = None
        return _Stepper(self, ordering, spec, validity, dt)


def controller_dt(t) -> float | None:
    """The `dt` a solver reports to py-pde's Controller at time t: None (its absolute windows,
    1e-12 for the end of a run, 1e-8 for a tracker's time) while float numbers at t resolve
    them, else one whose windows (1e-6 dt and dt/2) are 32 and 1.6e7 float spacings at t: with
    absolute windows a tracker due at a t past ~1e4 never fires (its final snapshot is lost)
    or fires forever at the same time (past 2**28, the run hangs)."""
    spacing = float(np.spacing(abs(float(t))))
    return None if 4 * spacing < 1e-12 else 3.2e7 * spacing


def check_memory(pde, grid, method: str, choice: Choice) -> None:
    """Refuse (ParameterError), before anything is allocated, a run on `grid` whose scheme and
    linear algebra need more than half the memory available: the scheme's ``grid_limit`` checks
    it (:meth:`icidr_pde.discretizations.grid_size.GridLimit.check_run`: a dense n x n array
    where this path has one). The grid alone is enough: the state need not exist yet."""
    limit = getattr(pde, "grid_limit", None)
    if limit is None:
        return
    shape = tuple(grid.shape)
    what = pde.cell.grid_words(shape)  # the scheme's cell names its grid
    thin = bool(getattr(pde, "is_thin", None) and pde.is_thin(grid))
    unknowns = len(pde.fields) * int(np.prod(shape))  # the size of the state on this grid
    memory = _solver(choice).memory(unknowns, method, choice.jacobian, thin)
    limit.check_run(what, unknowns, int(np.prod(shape)), method, memory)


def _solver(choice: Choice):
    """The linear solver of `choice` (one built by hand may name it only)."""
    return choice.solver if choice.solver is not None else named(choice.linear_solver, choice.engine)


def scheme_problem(pde, state, choice: Choice, rhs, stats: StepStatistics):
    """(Problem, Ordering) of the py-pde scheme `pde` on `state` for the engines, with its
    right-hand side `rhs(data, t)` (compiled), the Jacobian form of `choice`, the validity
    bounds of phi; the right-hand side calls are counted in `stats`."""
    spec, perm = jacobian_spec(pde, state, choice)  # a compiled Jacobian is loaded here
    ordering = Ordering(rhs, state.data.shape, perm, stats)
    validity = _validity(pde, state.data.shape, perm)
    patches = scheme_patches(pde, state, choice, perm)
    return make_problem(pde, ordering.to_engine(state.data), ordering, spec, validity, patches), ordering


def scheme_patches(pde, state, choice: Choice, perm, grid=None):
    """The scheme's right-hand side on blocks of its grid (``pde.patches``) where the engine
    distributes the grid (PETSc) in the scheme's own ordering, else None; of `state`'s grid, or
    of `grid` (no whole state)."""
    if choice.engine != "petsc" or perm is not None or not hasattr(pde, "patches"):
        return None
    patches = pde.patches(state) if grid is None else pde.patches(grid=grid)
    bounds = getattr(pde, "validity_bounds", None)
    if bounds is None or bounds() is None:
        return patches
    from . import state_bounds

    lo, hi = (float(b) for b in bounds())
    dof = patches.dof

    def inside(block) -> bool:  # the compiled test of make_problem's check, phi every dof-th value
        return state_bounds.inside(block, 0, dof, block.size // dof, lo, hi)

    return dataclasses.replace(patches, inside=inside)


class Ordering:
    """The scheme's state data (its shape) and the engine's vector (permuted by `perm`, or
    not), with the scheme's right-hand side `rhs(data, t)` on the engine's vector."""

    def __init__(self, rhs, shape, perm, stats: StepStatistics):
        self.rhs, self.shape, self.perm, self.stats = rhs, shape, perm, stats
        self.inverse = None if perm is None else np.argsort(perm)
        self.native = np.empty(shape)  # reused by fun_into
        self._native_flat = self.native.reshape(-1)

    def to_native(self, y):
        """Engine vector -> state data: always a fresh writable C array (CVODE passes read-only views)."""
        return (np.array(y, dtype=float) if self.perm is None else y[self.inverse]).reshape(self.shape)

    def to_engine(self, data):
        y = np.array(data, dtype=float).ravel()
        return y if self.perm is None else y[self.perm]

    def fun(self, t, y):
        self.stats.n_rhs += 1
        rate = self.rhs(self.to_native(y), t).ravel()
        return rate if self.perm is None else rate[self.perm]

    def fun_into(self, t, y, out):
        """The same numbers as :meth:`fun`, without its temporaries."""
        self.stats.n_rhs += 1
        if self.perm is None:
            self._native_flat[:] = y
            out[:] = self.rhs(self.native, t).reshape(-1)
        else:
            np.take(y, self.inverse, out=self._native_flat)
            np.take(self.rhs(self.native, t).reshape(-1), self.perm, out=out)


def conserved(pde, state, perm):
    """(weights, anchor) of the mass of phi in the engine's ordering, or (None, None)."""
    weights = getattr(pde, "quadrature_weights", None)
    if weights is None:
        return None, None
    n = state.data[0].size
    c = np.zeros(state.data.size)
    c[:n] = np.ravel(weights(state.grid))
    native = np.arange(c.size) if perm is None else np.asarray(perm)
    position = np.argsort(native)
    return c[native], position[native % n]  # a column's anchor: phi at its own node


def jacobian_spec(pde, state, choice: Choice):
    """The JacobianSpec of the chosen form and the permutation into the engine's ordering."""
    mode = choice.jacobian
    if choice.memory_mode == "analytic-band":
        perm, lband, uband = pde.interleaving(state)
        return JacobianSpec("analytic", band=(lband, uband), band_jac=pde.make_band_jacobian(state)), perm
    if mode == "banded-fd":
        perm, lband, uband = pde.interleaving(state)
        weights, anchor = conserved(pde, state, perm)
        return JacobianSpec(mode, band=(lband, uband), weights=weights, anchor=anchor), perm
    if mode == "analytic":
        return JacobianSpec(mode, jac=pde.make_jacobian(state)), None
    if mode == "sparse":
        return JacobianSpec(mode, jac=pde.make_jacobian(state), sparsity=pde.jacobian_sparsity(state)), None
    if mode in ("sparse-fd", "colored-fd"):
        weights, anchor = conserved(pde, state, None) if mode == "sparse-fd" else (None, None)
        return JacobianSpec(mode, sparsity=pde.jacobian_sparsity(state), weights=weights, anchor=anchor), None
    solver = _solver(choice) if choice.engine != "petsc" else None
    if isinstance(solver, Preconditioned):  # GMRES preconditioned by what the analytic sparse Jacobian gives
        return solver.jacobian_spec(pde, state, mode), None
    weights, anchor = conserved(pde, state, None)
    line = getattr(pde, "line_pattern", lambda state: None)(state) if mode == "krylov" else None
    if line is not None:  # a thin cell: GMRES preconditioned along the walls' normal
        mass = cell_mass(state)
        return JacobianSpec(mode, jac=pde.make_jacobian(state), line_pattern=line, weights=mass,
                            anchor=np.arange(mass.size) % state.data[0].size), None
    return JacobianSpec(mode, weights=weights, anchor=anchor), None


def _validity(pde, shape, perm):
    """(inside(y), margins_into(y, out)) on the engine's vector without reordering it
    (compiled, :mod:`icidr_pde.engines.state_bounds`), or None where the discretization has no
    validity_margins or validity_bounds, or its phi entries are not evenly spaced in the
    engine's ordering."""
    bounds = getattr(pde, "validity_bounds", None)
    if getattr(pde, "validity_margins", None) is None or bounds is None or bounds() is None:
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


def make_problem(pde, y0, ordering: Ordering, spec: JacobianSpec, validity, patches=None) -> Problem:
    """The engines' Problem of a py-pde scheme in the engine's ordering (`patches`: the scheme's
    right-hand side on blocks of its grid, :func:`scheme_patches`)."""
    check_state = getattr(pde, "check_state", lambda data: None)
    to_native = ordering.to_native

    def generic_check(y):
        return invalid_state(y, check_state, to_native)

    pde_margins = getattr(pde, "validity_margins", None)
    margins = None if pde_margins is None else (lambda y: pde_margins(to_native(y)))
    margins_into, check = None, generic_check
    if validity is not None:
        inside, margins_into = validity

        def check(y):  # the message, only for a state outside
            return None if inside(y) else generic_check(y)

    return Problem(y0=y0, fun=ordering.fun, fun_into=ordering.fun_into, jacobian=spec, check=check,
                   margins=margins, margins_into=margins_into, patches=patches)


class _Stepper:
    """stepper(state, t_start, t_end) of :meth:`StiffSolver.make_stepper`: the engine created
    at the first call, advanced to t_end at each call."""

    def __init__(self, solver: StiffSolver, ordering: Ordering, spec: JacobianSpec, validity, dt):
        self.solver, self.ordering, self.spec, self.validity, self.dt = solver, ordering, spec, validity, dt
        self.engine = None

    def fail(self, reason: str):
        stats = self.solver.stats
        if self.engine is not None:
            stats.n_steps, stats.n_jac, stats.n_lu = self.engine.counts()
        t_good, y_good = self.solver.last_good
        raise SimulationFailed(t_good, reason, self.ordering.to_native(y_good).copy())

    def advance(self, t):
        failure = self.engine.advance(t)
        if failure is not None:
            self.solver.last_good = failure[:2]
            self.fail(failure[2])

    def start(self, state, t_start):
        """Check the initial state and its rates, then create the engine at t_start."""
        solver = self.solver
        y0 = self.ordering.to_engine(state.data)
        solver.last_good = (t_start, y0.copy())
        problem = make_problem(solver.pde, y0, self.ordering, self.spec, self.validity, solver.patches)
        reason = problem.check(y0)
        if reason:
            self.fail(f"initial state invalid: {reason}")
        with np.errstate(all="ignore"):
            reason = nonfinite_rates(self.ordering.rhs(np.array(state.data), t_start), t_start)
        if reason:
            self.fail(reason)
        engine_name = solver.choice.engine
        self.engine = engine_class(engine_name)(solver.method, problem, t_start, rtol=solver.rtol, atol=solver.atol,
                                                max_step=solver.max_step, first_step=self.dt,
                                                linear_solver=solver.choice.solver or solver.choice.linear_solver,
                                                max_order=solver.choice.max_order)
        solver.info["linear_solver"] = self.engine.linear_solver

    def __call__(self, state, t_start: float, t_end: float) -> float:
        solver = self.solver
        if solver.interrupted is not None:  # stopped inside the previous call: py-pde ends here
            raise KeyboardInterrupt
        if self.engine is None:
            self.start(state, t_start)
        try:
            self.advance(t_end)
            state.data[...] = self.ordering.to_native(self.engine.value_at(t_end))
        except KeyboardInterrupt:
            # Ctrl-C inside the loop: end this call at its start, whose state is known, as
            # py-pde would have at that interrupt; raised again next call
            solver.interrupted = t_start
            return t_start
        finally:
            stats = solver.stats
            stats.n_steps, stats.n_jac, stats.n_lu = self.engine.counts()
            # the time windows of py-pde's Controller, resolvable at t (see controller_dt)
            solver.info.update(steps=stats.n_steps, n_rhs=stats.n_rhs, dt=controller_dt(t_end))
        return t_end
