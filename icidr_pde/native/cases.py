"""The native engine's cases and their compiled problems.

:func:`native_case` is :func:`icidr_pde.case.build_case` on the py-pde-free core the compiled
problem of a scheme is built on (:func:`core_class`), with that problem (:func:`compiled_problem`:
:class:`~icidr_pde.native.FdProblem`, :class:`~icidr_pde.native.cheb.ChebProblem`,
:class:`~icidr_pde.native.fv2d.Fv2dProblem`) one call away.
"""

from __future__ import annotations

from functools import partial

from ..case import Case, build_case
from . import FdProblem, NativeProblem, NativeUnavailable
from .cheb import DENSE_SOLVER, ChebProblem
from .fv2d import Fv2dProblem

__all__ = ["core_class", "compiled_problem", "native_case", "NativeCase", "FdCase", "ChebCase", "Fv2dCase"]


def core_class(discretization: str):
    """The py-pde-free core the native engine's problem of `discretization` is built on: the
    registry's (fd, cheb), or the 2-D cell's :class:`~icidr_pde.discretizations.cartesian2d_core.CartesianCells`,
    which the registry does not name (its py-pde class builds its own grid)."""
    from ..discretizations.registry import get_scheme

    entry = get_scheme(discretization)
    if entry.core is not None:
        return entry.core_class()
    if discretization == "fv2d":
        from ..discretizations.cartesian2d_core import CartesianCells

        return CartesianCells
    raise NativeUnavailable(f"discretization {discretization!r} has no py-pde-free core")


def compiled_problem(case, **options) -> NativeProblem:
    """The compiled problem of the native engine on `case` (a core case of fd, cheb or fv2d)."""
    name = case.discretization
    if name == "fd":
        return FdProblem(case.rheology, case.N, case.H, advection=case.advection, V0=case.V0, **options)
    if name == "cheb":
        return ChebProblem(case.rheology, case.scheme.D,
                           **{"solver": DENSE_SOLVER, "weights": case.scheme.weights, **options})
    if name == "fv2d":
        c = case.scheme
        return Fv2dProblem(case.rheology, c.Nx, c.Nz, c.hx, c.hz, advection=c.advection, V0=c.V0, **options)
    raise NativeUnavailable(f"discretization {name!r} (the native engine has fd, cheb and fv2d)")


class NativeCase(Case):
    """A case with its compiled problem one call away."""

    def problem(self, **options) -> NativeProblem:
        """The compiled problem of this case (:func:`compiled_problem`)."""
        return compiled_problem(self, **options)


def native_case(discretization, rheology, scene, N, *, material=None, advection=None, scene_params=None):
    """The case of :func:`icidr_pde.case.build_case` on the core of `discretization` that the native
    engine integrates (:func:`core_class`); its state vector is the core's ``pack``: interleaved for
    fd, blocks for cheb, the data flattened for fv2d."""
    options = {} if advection is None else {"advection": advection}
    case = build_case(rheology, scene, discretization, N, material=material, options=options,
                      scene_params=scene_params, core=core_class(discretization))
    return NativeCase(case.scene, case.scheme, case.data)


#: the native case of each scheme (:func:`native_case`)
FdCase = partial(native_case, "fd")
ChebCase = partial(native_case, "cheb")
Fv2dCase = partial(native_case, "fv2d")
