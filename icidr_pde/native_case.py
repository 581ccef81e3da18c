"""The native engine's cases: :func:`icidr_pde.case.build_case` on the py-pde-free core a scheme's
compiled problem is built on, with that problem one call away (the cell's, :mod:`icidr_pde.cells`).
"""

from __future__ import annotations

from functools import partial

from .case import Case, build_case
from .cells import cell_of
from .native import NativeProblem, NativeUnavailable

__all__ = ["core_class", "compiled_problem", "native_case", "NativeCase", "FdCase", "ChebCase", "Plane2DCase"]


def core_class(discretization: str):
    """The py-pde-free core the native engine's problem of `discretization` is built on: the one
    its cell names, else the scheme registry's."""
    from .discretizations.registry import get_scheme

    cell = cell_of(discretization, default=None)
    core = cell.native_core(discretization) if cell is not None else None
    if core is not None:
        return core
    entry = get_scheme(discretization)
    if entry.core is not None:
        return entry.core_class()
    raise NativeUnavailable(f"discretization {discretization!r} has no py-pde-free core")


def compiled_problem(case, **options) -> NativeProblem:
    """The compiled problem of the native engine on `case` (a case on its scheme's core)."""
    name = case.discretization
    try:
        build = cell_of(name).native_problem(name)
    except ValueError as error:
        raise NativeUnavailable(str(error)) from None
    return build(case, **options)


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
Plane2DCase = partial(native_case, "fv2d")
