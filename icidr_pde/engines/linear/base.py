"""The linear solver of a run's Newton systems, and the registry its subclasses fill.

A :class:`LinearSolver` says what Jacobian form it needs (:class:`JacobianForm`), where it
applies (method, Jacobian mode, the scheme's :class:`~icidr_pde.engines.choose.JacobianStructure`),
the memory it allocates per unknown beyond the scheme's own (:class:`Memory`, which
:mod:`icidr_pde.discretizations.grid_size` checks), its display name (:attr:`~LinearSolver.name`,
what a Result's settings record) and how it configures CVODE through scikit-sundae
(:meth:`~LinearSolver.cvode_options`) and, where PETSc has it, PETSc's KSP and PC types.

A subclass that names itself (``name``) and the Jacobian modes it serves (``modes``)
registers one instance in :data:`SOLVERS`, ordered by ``preference``:
:func:`~icidr_pde.engines.choose.choose` takes the first that applies. Light: no numpy,
scipy or scikit-sundae at import (the native run path imports the registry).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["LinearSolver", "JacobianForm", "Memory", "SOLVERS", "unregister", "jacobian_modes", "solver_for",
           "named", "fun_into", "cell_mass"]

#: the registered linear solvers, most preferred first (filled by the subclasses themselves)
SOLVERS: list["LinearSolver"] = []


@dataclass(frozen=True)
class JacobianForm:
    """The Jacobian a solver needs: `kind` 'dense', 'banded' (the bandwidths are the scheme's
    ordering's, :meth:`interleaving`), 'sparse' (the scheme's pattern) or 'matrix-free'; `data`:
    the :class:`~icidr_pde.engines.base.JacobianSpec` fields its preconditioner is built from."""

    kind: str
    data: tuple[str, ...] = ()


@dataclass(frozen=True)
class Memory:
    """What a solver allocates for n unknowns beyond its scheme's estimate: `bytes`, what they
    hold (`note`), how the memory check names the Jacobian (`label`) and a hint where a cheaper
    path exists (`hint`, '' or '; ...')."""

    bytes: float
    note: str
    label: str
    hint: str = ""


class LinearSolver:
    """A solver of the Newton systems (I - gamma J) x = r of one engine's methods.

    Class attributes: `name` (the display name), `modes` (the ``jacobian`` values it serves,
    the user-facing option), `methods` (the methods whose Newton systems it solves), `engine`
    (the engine that sets it up), `preference` (the registry's order), `form`
    (:class:`JacobianForm`), `krylov` (GMRES: CVODE's linear tolerance factor is the engine's),
    `delta_gamma` (the change of gamma that refactors the Newton matrix, where it is not CVODE's
    default), `petsc` ((KSP type, PC type) of the same solver in PETSc, or None).
    """

    name = ""
    modes: tuple[str, ...] = ()
    methods: tuple[str, ...] = ()
    engine = "sundae"
    preference = 0.0
    form = JacobianForm("dense")
    krylov = False
    delta_gamma: float | None = None
    petsc: tuple[str, str] | None = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name") and cls.modes:
            _register(cls())

    def __eq__(self, other):
        return type(self) is type(other) and vars(self) == vars(other)

    def __hash__(self):
        return hash(type(self))

    def __repr__(self):
        return f"<{type(self).__name__}: {self.name}>"

    def applies(self, method: str, mode: str, structure) -> bool:
        """Whether this solver takes `method`'s Newton systems with Jacobian `mode` on a scheme
        of this structure (:class:`~icidr_pde.engines.choose.JacobianStructure`)."""
        return method in self.methods and mode in self.modes and self.offered(mode, structure)

    def offered(self, mode: str, structure) -> bool:
        """Whether the scheme's structure has what this solver needs (the mode is checked before)."""
        return True

    def memory(self, n: int, method: str, mode: str, thin: bool = False) -> Memory:
        """What it allocates for n unknowns beyond the scheme's estimate (`thin`: a thin 2-D cell)."""
        return Memory(0.0, "", repr(mode))

    def cvode_options(self, problem, rtol: float, atol: float) -> dict:
        """scikit-sundae's CVODE options of this solver on `problem` (:class:`~icidr_pde.engines.base.Problem`)."""
        raise NotImplementedError(f"{self.name} is not a linear solver of CVODE through scikit-sundae")

    def set_up_name(self, options: dict) -> str:
        """The name of what :meth:`cvode_options` set up (`options`: CVODE's options)."""
        return self.name


def _register(solver: LinearSolver) -> None:
    unregister(type(solver))
    SOLVERS.append(solver)
    SOLVERS.sort(key=lambda s: s.preference)  # stable: equal preferences keep their order of definition


def unregister(cls: type) -> None:
    """Take the solver of class `cls` out of the registry (a test's own solver, after the test)."""
    SOLVERS[:] = [s for s in SOLVERS if type(s) is not cls]


def jacobian_modes(method: str) -> tuple[str, ...]:
    """The Jacobian modes of `method`, its default first: the modes of its solvers in the registry's order."""
    return tuple(dict.fromkeys(m for s in SOLVERS if method in s.methods for m in s.modes))


def solver_for(method: str, mode: str, structure) -> LinearSolver:
    """The first registered solver that takes `method` with Jacobian `mode` on `structure`."""
    for solver in SOLVERS:
        if solver.applies(method, mode, structure):
            return solver
    raise LookupError(f"no linear solver takes method {method!r} with jacobian {mode!r}")


def named(name, engine: str = "sundae") -> LinearSolver:
    """`name` itself where it is a solver, else the registered solver of `engine` of that display name."""
    if isinstance(name, LinearSolver):
        return name
    for solver in SOLVERS:
        if solver.engine == engine and solver.name == name:
            return solver
    raise ValueError(f"`linear_solver` must be one of {[s.name for s in SOLVERS if s.engine == engine]}; "
                     f"got {name!r}")


def fun_into(problem):
    """fun_into(t, y, out) of `problem` (wrapping its `fun` where it has none)."""
    if problem.fun_into is not None:
        return problem.fun_into
    fun = problem.fun

    def into(t, y, out):
        out[:] = fun(t, y)

    return into


def cell_mass(state):
    """The mass weights of a finite-volume state of equal cells: 1 on phi (field 0), 0 elsewhere."""
    import numpy as np

    mass = np.zeros(state.data.size)
    mass[:state.data[0].size] = 1.0
    return mass
