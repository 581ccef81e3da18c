"""Discretizations of the shear-cell equations, side by side, behind one contract.

* :mod:`.registry` -- :data:`SCHEMES` (names, labels, options, grid limits) and
  :data:`DISCRETIZATIONS` (name -> py-pde class, loaded on lookup), importing no py-pde;
* :mod:`.core`, :mod:`.fd_core`, :mod:`.cheb_core` -- the 1-D schemes without py-pde:
  finite volumes (``fd``, option ``advection``) and Chebyshev-Gauss-Lobatto collocation
  (``cheb``), with :mod:`.chebyshev` (Trefethen's operators) and :mod:`.grid_size` (the
  largest grids);
* :mod:`.base`, :mod:`.fd`, :mod:`.cheb` -- their py-pde classes, thin adapters over the cores;
  :mod:`.cartesian2d` -- finite volumes on the 2-D x-periodic cell (``fv2d``);
* ``templates/`` -- the compiled loop kernels, combined with any law by
  :func:`icidr_pde.rheology.codegen.compose`, printed as C for the native engine.

Importing this package imports no py-pde: the py-pde classes load on first access.
"""

from .registry import ADVECTION_SCHEMES, DISCRETIZATIONS, SCHEMES, get_discretization, get_scheme

__all__ = ["DISCRETIZATIONS", "SCHEMES", "ShearCellBase", "get_discretization", "get_scheme", "ShearCellPDE",
           "ChebyshevShearCellPDE", "ShearCell2DPDE", "ADVECTION_SCHEMES"]

_LAZY = {"ShearCellBase": ".base", "ShearCellPDE": "..cells.shear1d.fd", "ChebyshevShearCellPDE": "..cells.shear1d.cheb",
         "ShearCell2DPDE": "..cells.plane2d.pde"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
