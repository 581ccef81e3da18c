"""Material and input validation for the stability toolkit.

The material is the simulator's :class:`icidr_pde.rheology.Material` (laws (2.10)-(2.11)
with Table 1 by default, or any other friction/dilatancy law); this module only adds the
argument checks of the toolkit's public functions.
"""

from __future__ import annotations

import math

import numpy as np

from icidr_pde.rheology import RHEOLOGIES, TABLE1, Material

__all__ = ["TABLE1", "default_material", "material_params", "check_phi", "check_rate", "check_xi",
           "check_rheology_name"]


def default_material(material=None) -> Material:
    """`material`, or the Table 1 :class:`~icidr_pde.rheology.Material` if None."""
    if material is None:
        return Material()
    if not isinstance(material, Material):
        raise TypeError(f"`material` must be an icidr_pde.rheology.Material; got {material!r}")
    return material


def material_params(material=None) -> dict:
    """Parameters of `material` (default Table 1) by name, as floats."""
    material = default_material(material)
    return dict(zip(material.parameter_names(), material.params))


def check_phi(phi, material=None, name: str = "phi") -> np.ndarray:
    """Validate packing fractions: finite and in the material's inertial range."""
    arr = np.asarray(phi, dtype=float)
    if arr.size == 0:
        raise ValueError(f"`{name}` must not be empty")
    return default_material(material).check_phi(arr, name)


#: magnitudes of strain rates and wavenumbers the symbols take: beyond them the coefficients
#: (powers of the rates, xi^2) overflow or underflow double precision (--uz 1e308 overflowed,
#: --uz 1e-300 --wz 1e-300 gave infinities in Gamma); measured finite at 1e-100 and 1e100
RATE_RANGE = (1e-100, 1e100)


def check_rate(value, name: str) -> np.ndarray:
    """Validate a strain-rate component (u_z or w_z): 0 or a magnitude in :data:`RATE_RANGE`."""
    arr = np.asarray(value, dtype=float)
    low, high = RATE_RANGE
    size = np.abs(arr)
    if not np.all(np.isfinite(arr)) or np.any((size != 0) & ((size < low) | (size > high))):
        raise ValueError(f"`{name}` must be 0 or a number of magnitude in [{low:g}, {high:g}]; got {value!r}")
    return arr


def check_xi(xi, name: str = "xi") -> float:
    """Validate a wavenumber: in :data:`RATE_RANGE`."""
    low, high = RATE_RANGE
    try:
        x = float(xi)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a number in [{low:g}, {high:g}]; got {xi!r}") from None
    if not math.isfinite(x) or not low <= x <= high:
        raise ValueError(f"`{name}` must lie in [{low:g}, {high:g}]; got {xi!r}")
    return x


def check_rheology_name(name: str) -> str:
    """Validate a rheology name against the simulator's registry."""
    if name not in RHEOLOGIES:
        raise ValueError(f"`rheology` must be one of {sorted(RHEOLOGIES)}; got {name!r}")
    return name
