"""icidr-pde: the mu(I),Phi(I) and iCIDR rheologies of dense granular flow on py-pde.

Schaeffer, Barker, Tsuji, Gremaud, Shearer & Gray (2019), J. Fluid Mech. 874, 926-951.

The public names are loaded on first use (PEP 562): ``import icidr_pde`` alone imports
neither py-pde nor numba, so that the command line's ``--help`` and the subcommands that
need neither start fast; ``icidr_pde.run`` imports what a run needs the first time it is
looked up.
"""

from __future__ import annotations

import importlib

# public name -> submodule that defines it
_EXPORTS = {
    "run": "api",
    "build_case": "case", "make_pde": "case",
    "DISCRETIZATIONS": "discretizations", "ChebyshevShearCellPDE": "discretizations",
    "ShearCellPDE": "discretizations", "ShearCell2DPDE": "discretizations",
    "SimulationFailed": "engines.base", "StiffSolver": "engines.stiff",
    "Result": "result",
    "ICIDR": "rheology", "RHEOLOGIES": "rheology", "Material": "rheology", "MuIPhiI": "rheology",
    "define_rheology": "rheology", "get_rheology": "rheology",
    "SCENES": "scenes", "get_scene": "scenes",
}

__all__ = [
    "run", "build_case", "make_pde", "Result", "Material", "MuIPhiI", "ICIDR", "get_rheology",
    "define_rheology", "RHEOLOGIES", "ShearCellPDE", "ShearCell2DPDE", "ChebyshevShearCellPDE", "DISCRETIZATIONS",
    "StiffSolver", "SimulationFailed", "SCENES", "get_scene",
]
__version__ = "0.1.0"

# py-pde's movies (matplotlib's FFMpegWriter) run the ffmpeg of the imageio-ffmpeg wheel when they
# find no other, from the moment matplotlib is loaded: why here, icidr_pde/ffmpeg.py
importlib.import_module(".ffmpeg", __name__).when_matplotlib_loads()


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__():  # the public names, not the module's own imports
    return sorted(set(__all__) | {"__version__"})
