"""Constitutive laws of dense granular flow, written once on invariants (see :mod:`.base`).

* :mod:`.laws` -- friction mu(I) and dilatancy Phi(I)/Psi(phi) laws (2.10), (2.11), the
  saturating law of section 2; :mod:`.material` -- :class:`Material` (Table 1 by default);
* :mod:`.base` -- :class:`Rheology`: (phi, div u, ||S||) -> (p, c) with tau = c S, chi (A18);
* :mod:`.mui`, :mod:`.icidr` -- the two rheologies of the paper, one class per file;
* :mod:`.cidr` -- the workbench: a CIDR law from (Y, f) (equation of state solved from the
  flow rule, stress from the yield law); :mod:`.direct` -- a law given as (p, tau), and
  :func:`define_rheology` (p, c); :mod:`.expressions` -- the pieces both are built of;
  :mod:`.nonmonotonic`, :mod:`.saturating`, :mod:`.mu_psi`, :mod:`.blended` -- the laws built
  with them (section 7);
* :mod:`.registry` -- :data:`RHEOLOGIES`, the laws by name; :mod:`.law_files` -- laws written
  in files (Python, declarative :mod:`.declarative`); :mod:`.lookup` -- :func:`get_rheology`,
  a law by name or file;
* :mod:`.kinematics` -- adapters from a geometry's strain rates to the invariants;
* :mod:`.codegen` -- numeric kernels and Jacobians generated from the sympy definitions,
  compiled by numba once per installation.

Everything is non-dimensional with the scalings (3.12): d = rho_* = V0 = 1.
"""

from .base import Rheology, chi
from .registry import RHEOLOGIES
from .icidr import ICIDR
from .kinematics import INVARIANTS, PLANE_FLOW, SHEAR_CELL, Kinematics
from .laws import (DILATANCY_LAWS, FRICTION_LAWS, TABLE1, DilatancyLaw, FrictionLaw, LinearDilatancy,
                   MuOfI, SaturatingDilatancy)
from .material import Material, mu_of_I
from .mui import MuIPhiI
from .errors import LawError
from .cidr import CIDRLaw, define_cidr_law
from .direct import DirectLaw, define_direct_law, define_rheology
from .law_files import load_law_file
from .lookup import get_rheology
from . import blended, mu_psi, nonmonotonic, saturating  # noqa: F401,E402  (the shipped workbench laws)

__all__ = [
    "Material", "mu_of_I", "Rheology", "MuIPhiI", "ICIDR", "RHEOLOGIES", "get_rheology", "define_rheology", "chi",
    "TABLE1", "FrictionLaw", "DilatancyLaw", "MuOfI", "LinearDilatancy", "SaturatingDilatancy",
    "FRICTION_LAWS", "DILATANCY_LAWS", "Kinematics", "INVARIANTS", "SHEAR_CELL", "PLANE_FLOW",
    "CIDRLaw", "DirectLaw", "LawError", "define_cidr_law", "define_direct_law", "load_law_file",
]
