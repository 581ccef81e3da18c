"""Discretizations of the shear-cell equations, side by side, behind one contract.

* :mod:`.base` -- :class:`ShearCellBase`, the written contract (module docstring), and the
  registry :data:`DISCRETIZATIONS` that every scheme joins by defining a ``name``;
* :mod:`.fd` -- finite volumes on py-pde's grid (``fd``, option ``advection``);
* :mod:`.cheb` -- Chebyshev-Gauss-Lobatto collocation (``cheb``);
* :mod:`.cartesian2d` -- finite volumes on the 2-D x-periodic cell (``fv2d``);
* ``templates/`` -- the compiled loop kernels, combined with any law by
  :func:`icidr_pde.rheology.codegen.compose`.
"""

from .base import DISCRETIZATIONS, ShearCellBase, get_discretization
from .cartesian2d import ShearCell2DPDE
from .cheb import ChebyshevShearCellPDE
from .fd import ADVECTION_SCHEMES, ShearCellPDE

__all__ = ["DISCRETIZATIONS", "ShearCellBase", "get_discretization", "ShearCellPDE",
           "ChebyshevShearCellPDE", "ShearCell2DPDE", "ADVECTION_SCHEMES"]
