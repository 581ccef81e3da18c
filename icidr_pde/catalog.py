"""The built-in names the command line offers, without importing the modules behind them.

``icidr-pde run --help`` and a ``run`` on the native engine import neither py-pde (the
discretizations register themselves on import) nor scipy (the integrators): the run
parser takes its choices from here. tests/test_native.py checks that the discretizations
are exactly what the registry holds (``discretizations.DISCRETIZATIONS``); the methods and
Jacobian modes are the engines' registry's (:mod:`icidr_pde.engines`, light).
"""

from .engines import JACOBIAN_MODES, METHODS

__all__ = ["DISCRETIZATIONS", "DISCRETIZATION_OPTIONS", "METHODS", "JACOBIAN_MODES"]

#: discretization names, in registration order
DISCRETIZATIONS = ("fv2d", "cheb", "fd")
#: option -> (the discretizations that have it, its valid values with the default first)
DISCRETIZATION_OPTIONS = {"advection": (("fv2d", "fd"), ("upwind", "central"))}
