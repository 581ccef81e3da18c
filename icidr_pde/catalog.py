"""The built-in names the command line offers, without importing the modules behind them.

``icidr-pde run --help`` and a ``run`` on the native engine import neither py-pde (the
discretizations register themselves on import) nor scipy (the integrators): the run
parser takes its choices from here. tests/test_native.py checks that these are exactly what
the registries hold (``discretizations.DISCRETIZATIONS``, ``integrator.METHODS``,
``integrator.JACOBIAN_MODES``).
"""

__all__ = ["DISCRETIZATIONS", "DISCRETIZATION_OPTIONS", "METHODS", "JACOBIAN_MODES"]

#: discretization names, in registration order
DISCRETIZATIONS = ("fv2d", "cheb", "fd")
#: option -> (the discretizations that have it, its valid values with the default first)
DISCRETIZATION_OPTIONS = {"advection": (("fv2d", "fd"), ("upwind", "central"))}
METHODS = ("BDF", "Radau", "LSODA", "CVODE")
JACOBIAN_MODES = ("analytic", "sparse-fd", "banded-fd", "colored-fd", "krylov", "sparse", "none")
