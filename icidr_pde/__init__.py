"""icidr-pde: the mu(I),Phi(I) and iCIDR rheologies of dense granular flow on py-pde.

Schaeffer, Barker, Tsuji, Gremaud, Shearer & Gray (2019), J. Fluid Mech. 874, 926-951.
"""

from .api import make_pde, run
from .integrator import SimulationFailed, StiffSolver
from .pdes import ShearCellPDE
from .result import Result
from .rheology import ICIDR, Material, MuIPhiI, get_rheology
from .scenes import SCENES, get_scene

__all__ = [
    "run", "make_pde", "Result", "Material", "MuIPhiI", "ICIDR", "get_rheology",
    "ShearCellPDE", "StiffSolver", "SimulationFailed", "SCENES", "get_scene",
]
__version__ = "0.1.0"
