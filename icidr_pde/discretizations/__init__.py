"""What the schemes of every cell share, behind one contract.

* :mod:`.registry` -- :data:`SCHEMES` (names, labels, options, grid limits) and
  :data:`DISCRETIZATIONS` (name -> py-pde class, loaded on lookup), importing no py-pde;
* :mod:`.base` -- the contract of a scheme's py-pde class; :mod:`.core` -- the base of the 1-D
  cores, the validity of phi and the walls' ghost maps (3.9); :mod:`.chebyshev` (Trefethen's
  operators) and :mod:`.grid_size` (the largest grids).

The schemes themselves are in their cells' folders (:mod:`icidr_pde.cells`): finite volumes
(``fd``, option ``advection``) and Chebyshev-Gauss-Lobatto collocation (``cheb``) in
``cells/shear1d/``, finite volumes on the 2-D x-periodic cell (``fv2d``) in ``cells/plane2d/``,
each with its py-pde-free core, its py-pde adapter and its ``templates/`` (the compiled loop
kernels, combined with any law by :func:`icidr_pde.rheology.codegen.compose`, printed as C for
the native engine).

Importing this package imports no py-pde: the py-pde classes load on first access.
"""

from .registry import ADVECTION_SCHEMES, DISCRETIZATIONS, SCHEMES, get_discretization, get_scheme

__all__ = ["DISCRETIZATIONS", "SCHEMES", "ShearCellBase", "get_discretization", "get_scheme", "ShearCellPDE",
           "ChebyshevShearCellPDE", "ShearCell2DPDE", "ADVECTION_SCHEMES"]

_LAZY = {"ShearCellBase": ".base", "ShearCellPDE": "..cells.shear1d.fd",
         "ChebyshevShearCellPDE": "..cells.shear1d.cheb",
         "ShearCell2DPDE": "..cells.plane2d.pde"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
