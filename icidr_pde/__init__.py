"""icidr-pde: the mu(I),Phi(I) and iCIDR rheologies of dense granular flow on py-pde.

Schaeffer, Barker, Tsuji, Gremaud, Shearer & Gray (2019), J. Fluid Mech. 874, 926-951.
"""

from .api import run
from .case import build_case, make_pde
from .discretizations import DISCRETIZATIONS, ChebyshevShearCellPDE, ShearCellPDE
from .integrator import SimulationFailed, StiffSolver
from .result import Result
from .rheology import ICIDR, RHEOLOGIES, Material, MuIPhiI, define_rheology, get_rheology
from .scenes import SCENES, get_scene

__all__ = [
    "run", "build_case", "make_pde", "Result", "Material", "MuIPhiI", "ICIDR", "get_rheology",
    "define_rheology", "RHEOLOGIES", "ShearCellPDE", "ChebyshevShearCellPDE", "DISCRETIZATIONS",
    "StiffSolver", "SimulationFailed", "SCENES", "get_scene",
]
__version__ = "0.1.0"
