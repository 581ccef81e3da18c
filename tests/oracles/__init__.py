"""Independent numpy implementations of the schemes: the truth the compiled kernels are tested against.

``numpy_rhs(pde, grid)`` of each scheme module is the rates of the py-pde class `pde` on `grid`.
"""

from . import cartesian2d, cheb, fd

#: discretization name -> its oracle's numpy_rhs(pde, grid)
NUMPY_RHS = {"fd": fd.numpy_rhs, "cheb": cheb.numpy_rhs, "fv2d": cartesian2d.numpy_rhs}


def oracle_rhs(pde, state):
    """rhs(data, t) of an implementation independent of the compiled kernels: the scheme's oracle."""
    return NUMPY_RHS[pde.name](pde, state.grid)
