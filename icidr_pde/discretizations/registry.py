"""The registry of the schemes, readable without importing py-pde, numba or scipy.

Each scheme is one :class:`Scheme` entry: its name, label, dimension, the N of a grid when
none is given, its options (keyword -> valid values, the default first), its grid limit
(:mod:`.grid_size`), where its py-pde-free core lives (the 1-D schemes) and where its py-pde
adapter lives (loaded on first use). The CLI takes its choices from here; the core and
adapter classes take their name, label, default N and options from their entry.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass, field

from .grid_size import CHEB, FD, PLANE2D, GridLimit

__all__ = ["Scheme", "SCHEMES", "DISCRETIZATIONS", "ADVECTION_SCHEMES", "ADVECTION_SCHEMES_2D", "get_discretization",
           "get_scheme", "option_choices", "PYPDE_SOLVERS", "pypde_solver"]

#: advection in 1-D: first-order upwind (the default, as the paper's differences) or central
ADVECTION_SCHEMES = ("upwind", "central")
#: advection in 2-D: central by default (second order; no figure of the paper binds the 2-D cell,
#: docs/sim2d.md), upwind kept
ADVECTION_SCHEMES_2D = ("central", "upwind")


def _load(path: str):
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module, __package__), name)


@dataclass(frozen=True)
class Scheme:
    """One discretization of the shear-cell equations (see the module docstring)."""

    name: str
    label: str
    dim: int
    default_N: int
    grid_limit: GridLimit
    adapter: str
    core: str | None = None
    options: dict = field(default_factory=dict)

    def adapter_class(self) -> type:
        """The py-pde class (imports py-pde)."""
        return _load(self.adapter)

    def core_class(self) -> type:
        """The py-pde-free core (numpy only at import)."""
        if self.core is None:
            raise ValueError(f"discretization {self.name!r} has no py-pde-free core")
        return _load(self.core)


SCHEMES: dict[str, Scheme] = {s.name: s for s in (
    Scheme("fv2d", "finite volumes, 2-D", 2, 64, PLANE2D, "..cells.plane2d.pde:ShearCell2DPDE",
           options={"advection": ADVECTION_SCHEMES_2D}),
    Scheme("cheb", "Chebyshev", 1, 65, CHEB, "..cells.shear1d.cheb:ChebyshevShearCellPDE",
           "..cells.shear1d.cheb_core:Collocation"),
    Scheme("fd", "finite volumes", 1, 201, FD, "..cells.shear1d.fd:ShearCellPDE",
           "..cells.shear1d.fd_core:FiniteVolumes",
           options={"advection": ADVECTION_SCHEMES}),
)}


class _Adapters(Mapping):
    """name -> py-pde class, each imported when first looked up."""

    def __getitem__(self, name):
        return SCHEMES[name].adapter_class()

    def __iter__(self):
        return iter(SCHEMES)

    def __len__(self):
        return len(SCHEMES)

    def __contains__(self, name):
        return name in SCHEMES


#: name -> the scheme's py-pde class (loaded on lookup; names and options are in :data:`SCHEMES`)
DISCRETIZATIONS = _Adapters()


def get_scheme(name) -> Scheme:
    """The registry entry `name`."""
    try:
        return SCHEMES[name]
    except (KeyError, TypeError):
        raise ValueError(f"`discretization` must be one of {sorted(SCHEMES)}; got {name!r}") from None


def get_discretization(name) -> type:
    """The py-pde class registered as `name` (a class is returned as it is)."""
    if isinstance(name, type):
        return name
    return get_scheme(name).adapter_class()


def option_choices() -> dict[str, tuple[dict[str, str], tuple]]:
    """option -> ({scheme that has it: its default}, the valid values of all of them)."""
    out: dict[str, tuple] = {}
    for scheme in SCHEMES.values():
        for key, valid in scheme.options.items():
            defaults, values = out.get(key, ({}, ()))
            out[key] = ({**defaults, scheme.name: valid[0]}, tuple(dict.fromkeys(values + tuple(valid))))
    return out


def check_options(name: str, options: dict) -> dict:
    """The options of scheme `name` with defaults filled in; a clear error for an unknown
    option or a value outside its valid ones."""
    valid_options = get_scheme(name).options
    unknown = set(options) - set(valid_options)
    if unknown:
        raise ValueError(f"unknown option(s) {sorted(unknown)} for discretization {name!r}; "
                         f"valid: {sorted(valid_options)}")
    out = {}
    for key, valid in valid_options.items():
        value = options.get(key)
        value = valid[0] if value is None else value
        if value not in valid:
            raise ValueError(f"`{key}` must be one of {valid}; got {value!r}")
        out[key] = value
    return out


#: py-pde's solvers that this package defines, by the name py-pde knows them: where each is, loaded
#: on first use (py-pde finds a solver by name once its module has been imported). A scheme's
#: ``solve()`` takes "stiff" by default, the engines' :class:`~icidr_pde.engines.stiff.StiffSolver`:
#: the scheme names it, the engine registers it, and no scheme imports an engine
PYPDE_SOLVERS = {"stiff": "icidr_pde.engines.stiff:StiffSolver"}


def pypde_solver(solver):
    """`solver` as given, with py-pde's solver of that name registered if it is one of :data:`PYPDE_SOLVERS`."""
    if isinstance(solver, str) and solver in PYPDE_SOLVERS:
        _load(PYPDE_SOLVERS[solver])
    return solver
