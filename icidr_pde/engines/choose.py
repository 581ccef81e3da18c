"""One choice of engine, Jacobian and linear solver for a run.

:func:`choose` is the only place that decides, from the resolved settings (method, the
Jacobian asked for, the engine asked for) and what the cell of the run says of its scheme (the
structure of its Jacobian, what the native engine runs it with, why the native engine does not
take its grid), which engine integrates, with which Jacobian and linear solver, and, where
'native' was asked for and not taken, why (one line). An engine imports no cell: the run path
asks the cell (:func:`icidr_pde.cells.choice_asks`) and passes its answers in as plain values.
The linear solver is the first of the registry (:data:`icidr_pde.engines.linear.SOLVERS`, most
preferred first) that takes the method with that Jacobian on the scheme's structure; the method's
Jacobian modes are its solvers'. Light: numpy is not even needed.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..cvode_settings import A_STABLE_ORDER, BDF_MAX_ORDER
from ..validation import ParameterError, choice as checked_choice, integer
from . import ENGINES, METHODS
from .linear import SOLVERS, LinearSolver, compiled_solver, jacobian_modes, solver_for
from .linear.amg import AmgGmres
from .linear.gmres import PetscGmres, Preconditioned
from .linear.xfourier import XFourierGmres

__all__ = ["Choice", "JacobianStructure", "choose", "REQUESTS", "PETSC_METHOD", "DENSE_2D_CELLS",
           "CHOICES_2D", "BDF_MAX_ORDER", "A_STABLE_ORDER", "time_order", "AMG_SOLVER", "FOURIER_SOLVER"]

#: what a run may ask for: 'auto' takes the native engine where it applies, 'native' says why it
#: did not, 'pde' is always the Python engines (scipy, scikit-sundae) on the py-pde scheme,
#: 'petsc' is PETSc's TS on the py-pde scheme's sparse Jacobian (any method asked: PETSc's BDF)
REQUESTS = ("auto", "native", "pde", "petsc")
#: the method of the PETSc engine (PETSc's TSBDF; its -ts_type option changes it)
PETSC_METHOD = "PETSC-BDF"

#: the name of the linear solver of Jacobian mode 'amg' (:mod:`icidr_pde.engines.linear.amg`)
AMG_SOLVER = AmgGmres.name
#: the name of the linear solver of Jacobian mode 'fourier' (:mod:`icidr_pde.engines.linear.xfourier`)
FOURIER_SOLVER = XFourierGmres.name
#: dense Jacobians above this size are not differenced into scikit-sundae's hand-over array (256 MiB)
DENSE_HANDOVER_BYTES = 2**28


@dataclass(frozen=True)
class JacobianStructure:
    """What a scheme's Jacobian offers: a banded ordering (`banded`) and the analytic Jacobian
    in it (`band_jac`), a sparse pattern (`sparse`; else dense), a line preconditioner pattern
    where the cell is thin (`line`, 2-D cells), an analytic sparse Jacobian with no banded ordering
    (fields on a 2-D grid) for the algebraic multigrid and the x-Fourier preconditioners (`amg`;
    modes 'amg', 'fourier'), waves advected along a periodic direction (`advected`: the 2-D cell),
    whose eigenvalues lie near the imaginary axis, outside the A(alpha) sectors of BDF orders 3-5,
    so that only an A-stable order (<= :data:`A_STABLE_ORDER`) is stable at every step size."""

    banded: bool = False
    band_jac: bool = False
    sparse: bool = False
    line: bool = False
    amg: bool = False
    advected: bool = False

    @classmethod
    def of(cls, pde, state) -> "JacobianStructure":
        """The structure a py-pde scheme offers on `state` (any PDE: what it has)."""
        ordering = getattr(pde, "interleaving", lambda state: None)(state)
        sparsity = getattr(pde, "jacobian_sparsity", lambda state: None)(state)
        return cls(banded=ordering is not None, band_jac=ordering is not None and hasattr(pde, "make_band_jacobian"),
                   sparse=sparsity is not None, line=hasattr(pde, "line_pattern"),
                   amg=sparsity is not None and ordering is None and hasattr(pde, "make_jacobian"),
                   advected=getattr(pde, "advected_waves", False))


#: the largest 2-D grid (cells) on which a dense Newton matrix is allowed: 3 Nx Nz = 3072 unknowns,
#: 75 MB and ~1e10 flops per LU; 64^2 is 1.2 GB and ~6e11 flops per LU, where the default GMRES
#: takes seconds to t = 10
DENSE_2D_CELLS = 32 * 32
#: the Jacobian choices of the 2-D cell that are not dense, per method (the first: the default)
CHOICES_2D = {"CVODE": ("fourier", "krylov", "amg", "sparse"), "BDF": ("analytic", "sparse-fd", "colored-fd"),
              "Radau": ("analytic", "sparse-fd", "colored-fd")}


@dataclass(frozen=True)
class Choice:
    """engine (a key of :data:`~icidr_pde.engines.ENGINES`), jacobian (a Jacobian mode),
    linear_solver (the name of the solver of the Newton systems), reason (why 'native' was not
    taken, else ''), max_order (the highest BDF order the engine may take), warning (a setting
    asked for that is known to amplify modes the continuum damps, and the stable alternative;
    else ''), solver (the :class:`~icidr_pde.engines.linear.LinearSolver` itself)."""

    engine: str
    jacobian: str
    linear_solver: str
    reason: str = ""
    max_order: int = BDF_MAX_ORDER
    warning: str = ""
    solver: LinearSolver | None = None

    def solved_by(self, linear_solver: str) -> "Choice":
        """The same choice, its linear solver named as the engine set it up."""
        return replace(self, linear_solver=linear_solver)

    @property
    def memory_mode(self) -> str:
        """The Jacobian mode, 'analytic-band' where the analytic Jacobian is written into a band solver's
        band (:func:`icidr_pde.engines.stiff.jacobian_spec`)."""
        banded = self.solver is not None and self.solver.form.kind == "banded"
        return "analytic-band" if self.jacobian == "analytic" and banded else self.jacobian


def choose(*, method: str, jacobian: str | None = None, structure: JacobianStructure | dict,
           discretization: str | None = None, request: str = "auto", backend: str = "numba",
           native: tuple[str, str] | None = None, native_schemes: tuple[str, ...] = (), native_refusal: str = "",
           schemes: dict | None = None, native_unavailable: str | None = None, thin_cell: bool = False,
           cells: int | None = None, max_order: int | None = None) -> Choice:
    """The engine, Jacobian and linear solver of a run.

    Args:
        method: 'BDF', 'Radau', 'LSODA' or 'CVODE'
        jacobian: the mode asked for, None: the method's best on this structure
        structure: what the scheme's Jacobian offers (:class:`JacobianStructure`, or its flags)
        discretization: the scheme's registry name
        request: one of :data:`REQUESTS`
        backend: 'numba' or 'numpy' (the native engine is compiled)
        native: (Jacobian mode, linear solver name) of the native engine on the scheme, None: it has
            no compiled problem of it (:attr:`icidr_pde.cells.base.Cell.native`)
        native_schemes: every scheme the native engine has (what a refusal names)
        native_refusal: why the native engine does not take the run's grid (one line), or ''
            (:meth:`icidr_pde.cells.base.Cell.native_refusal`)
        schemes: every registered scheme's Jacobian structure (or its flags): which of them a refusal names
        native_unavailable: why the native engine cannot be built here (no compiler, ...), if known
        thin_cell: a 2-D cell with hx > THIN_CELL hz (the py-pde path preconditions its GMRES along z)
        cells: the cells of a 2-D grid (Nx Nz), if known: beyond :data:`DENSE_2D_CELLS` a dense
            Newton matrix (CVODE 'analytic' or 'none', BDF/Radau 'none', LSODA) is refused
        max_order: the highest BDF order asked for (1-5), None: the scheme's stable one
            (:func:`time_order`)

    (:func:`icidr_pde.cells.choice_asks` gives the keywords from `structure` to `cells` as the
    cell of a run states them.) The native engine is taken ('auto', 'native') with CVODE, the
    Jacobian mode of `native` (or none asked) and the numba backend, where the cell does not
    refuse the grid; never on the py-pde path ('pde', 'petsc').
    """
    checked_choice("engine", request, REQUESTS)
    checked_choice("method", method, METHODS)
    structure = _structure(structure)
    schemes = {name: _structure(flags) for name, flags in (schemes or {}).items()}
    order, warning = time_order(method, structure, max_order, request)
    reason = ""
    if request == "petsc" or method == PETSC_METHOD:
        return _petsc_choice(jacobian, structure, order, warning, schemes)
    if request != "pde":
        reason = native_unavailable or _not_native(method, jacobian, discretization, backend, native,
                                                   native_schemes) or native_refusal
        if not reason:
            solver = compiled_solver(*native[1:])
            return Choice("native", native[0], solver.name, max_order=order, warning=warning, solver=solver)
    mode = _jacobian_mode(jacobian_modes(method), method, jacobian, structure, thin_cell, schemes)
    solver = solver_for(method, mode, structure)
    if structure.amg and solver.form.kind == "dense" and cells is not None and cells > DENSE_2D_CELLS:
        raise ParameterError(_dense_2d(method, mode if jacobian is not None else None, solver.name, cells))
    engine = solver.engine if solver.engine in ENGINES else next(
        name for name, entry in ENGINES.items() if method in entry.methods and name != "native")
    return Choice(engine, mode, solver.name, reason, order, warning, solver)


def _dense_2d(method, mode, solver, cells) -> str:
    """Why a dense Newton matrix is refused on a 2-D grid of `cells` cells, and what works
    (`mode` None: the method's only choice there)."""
    n = 3 * cells
    works = "; ".join(f"with --method {m}: --jacobian " + " or ".join(modes) for m, modes in CHOICES_2D.items())
    asked = f"`jacobian`={mode!r} with method {method!r}" if mode else f"`method`={method!r}"
    return (f"{asked} on the 2-D cell is a {solver} of 3 x {cells} = {n} "
            f"unknowns ({8 * n * n / 1e9:.2g} GB, ~{n ** 3 / 3:.1e} flops per factorization); dense Newton "
            f"matrices are refused above {DENSE_2D_CELLS} cells. Choices that work: {works} "
            f"(default: CVODE with {CHOICES_2D['CVODE'][0]!r})")


def time_order(method: str, structure: JacobianStructure, asked: int | None = None,
               request: str = "auto") -> tuple[int, str]:
    """The highest BDF order of a run and, where the settings are known to amplify modes the
    continuum damps, a warning naming the stable alternative (else '').

    A scheme whose waves are advected along a periodic direction (``structure.advected``, the
    2-D cell) has eigenvalues i U xi near the imaginary axis; BDF orders 3-5 are not A-stable and
    amplify them at h U xi ~ 1-2.5, whatever the tolerance (a tighter one moves h U xi into the worst
    band), so such a scheme takes :data:`A_STABLE_ORDER` unless another order is asked. Elsewhere
    the spectrum lies inside BDF5's A(alpha) sector (1-D cells: within 45.3 degrees of the negative
    real axis, alpha = 51.8; tests/test_time_order.py) and the order is CVODE's
    :data:`BDF_MAX_ORDER`. scipy's BDF and LSODA cannot be capped: on an advected scheme they are
    warned about; Radau IIA is L-stable.
    """
    if asked is not None:
        asked = integer("max_order", asked, 1, BDF_MAX_ORDER)
    order = asked if asked is not None else (A_STABLE_ORDER if structure.advected else BDF_MAX_ORDER)
    if not structure.advected:
        return order, ""
    if order > A_STABLE_ORDER:
        return order, (f"max_order {order} amplifies short advected waves that the continuum damps (BDF orders "
                       f"3-5 are not A-stable); max_order {A_STABLE_ORDER}, the default here, is stable at "
                       "every step (docs/sim2d.md, 'Time integration')")
    if method in ("BDF", "LSODA") and request != "petsc":
        return order, (f"method {method!r} takes BDF orders up to {BDF_MAX_ORDER}, which amplify short "
                       "advected waves that the continuum damps; 'CVODE' (max order "
                       f"{A_STABLE_ORDER} here) or 'Radau' (L-stable) is stable at every step "
                       "(docs/sim2d.md, 'Time integration')")
    return order, ""


def _structure(flags) -> JacobianStructure:
    return flags if isinstance(flags, JacobianStructure) else JacobianStructure(**flags)


def _petsc_choice(jacobian, structure, max_order, warning, schemes) -> Choice:
    """The PETSc engine: the analytic sparse Jacobian, Newton-Krylov: GMRES preconditioned by the
    registry's first PETSc solver that applies (the x-Fourier inverse on the 2-D cell), else by
    block Jacobi/ILU."""
    if not structure.sparse:
        sparse = [name for name, offered in schemes.items() if offered.sparse]
        which = f" ({', '.join(sparse)})" if sparse else ""
        raise ParameterError(f"`engine`='petsc' needs a discretization with a sparse Jacobian{which}; got a dense one")
    if jacobian not in (None, "sparse"):
        raise ParameterError(f"`jacobian` must be 'sparse' on the PETSc engine; got {jacobian!r}")
    solver = next((s for s in SOLVERS if s.applies(PETSC_METHOD, "sparse", structure)), PetscGmres())
    return Choice("petsc", "sparse", solver.name, max_order=max_order, warning=warning, solver=solver)


#: why a Jacobian asked for is not the native engine's, by the native engine's mode
_NATIVE_MODE = {"analytic": "the native engine uses the analytic Jacobian",
                "krylov": "the native engine is matrix-free there: 'krylov'"}


def _not_native(method, jacobian, discretization, backend, native, native_schemes) -> str:
    """Why these settings cannot take the native engine (one line), or ''."""
    if native is None:
        has = " and ".join(filter(None, (", ".join(native_schemes[:-1]), "".join(native_schemes[-1:]))))
        return f"discretization {discretization!r} (the native engine has {has or 'none'})"
    if method != "CVODE":
        return f"method {method!r} (the native engine is CVODE)"
    if jacobian not in (None, native[0]):
        return f"jacobian {jacobian!r} ({_NATIVE_MODE.get(native[0], repr(native[0]))})"
    if backend != "numba":
        return f"backend {backend!r}"
    return ""


def _jacobian_mode(valid, method, jacobian, structure, thin_cell=False, schemes=None) -> str:
    """The Jacobian mode: the one asked for (checked against the method's and the scheme's),
    else the method's best on this structure (on a thin 2-D cell, whose x-coupling is weak, GMRES
    with the line preconditioner rather than the x-Fourier one)."""
    if jacobian is not None and jacobian not in valid:
        raise ParameterError(f"`jacobian` must be one of {valid} for method {method!r}; got {jacobian!r}")
    mode = valid[0] if jacobian is None else jacobian
    if method == "CVODE" and mode == "analytic" and not structure.band_jac and jacobian is None:
        mode = "banded-fd"  # no analytic band: difference quotients in the band, or below
    if mode == "banded-fd" and not structure.banded:
        if jacobian is not None:
            works = [m for m in CHOICES_2D.get(method, ()) if m in valid] if structure.amg else ["analytic", "none"]
            raise ParameterError("`jacobian`='banded-fd' needs a discretization with a banded ordering (finite "
                                 "differences, 1-D); use " + " or ".join(repr(m) for m in works or ["analytic"])
                                 + (f" with method {method!r}" if structure.amg else ""))
        # no banded ordering: Krylov where the Jacobian is sparse (2-D), preconditioned by the
        # x-average of the analytic one where there is one (the 2-D cell), else dense analytic (Chebyshev)
        mode = "krylov" if structure.sparse and "krylov" in valid else "analytic"
        if mode == "krylov" and not thin_cell:  # a thick cell: the preconditioner the registry prefers there
            mode = next((m for s in SOLVERS if isinstance(s, Preconditioned) and s.default and method in s.methods
                         for m in s.modes if m in valid and s.offered(m, structure)), mode)
    for solver in SOLVERS:  # a preconditioner asked for on a scheme that lacks what it is built from
        if isinstance(solver, Preconditioned) and mode in solver.modes and not solver.offered(mode, structure):
            raise ParameterError(solver.refusal(mode, valid, [name for name, offered in (schemes or {}).items()
                                                              if solver.offered(mode, offered)]))
    if mode in ("sparse-fd", "colored-fd") and not structure.sparse:  # dense differences labelled colored
        raise ParameterError(f"`jacobian`={mode!r} needs a sparse Jacobian; this "
                             "discretization's is dense: use 'analytic' or 'none'")
    return mode

