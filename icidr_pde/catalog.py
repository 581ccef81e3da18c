"""The built-in names the command line offers, without importing the modules behind them.

``icidr-pde run --help`` and a ``run`` on the native engine import neither py-pde (the
discretizations' py-pde classes) nor scipy (the integrators): the run parser takes its
choices from here. The discretizations come from their registry
(:mod:`icidr_pde.discretizations.registry`, which imports neither); the methods and Jacobian
modes are the engines' registry's (:mod:`icidr_pde.engines`, light).
"""

from .discretizations.registry import SCHEMES, option_choices
from .engines import JACOBIAN_MODES, METHODS

__all__ = ["DISCRETIZATIONS", "DISCRETIZATION_OPTIONS", "METHODS", "JACOBIAN_MODES"]

#: discretization names, in registry order
DISCRETIZATIONS = tuple(SCHEMES)
#: option -> ({discretization that has it: its default}, the valid values of all of them)
DISCRETIZATION_OPTIONS = option_choices()
