"""Material parameters and input validation for the stability toolkit.

The default material is the simulator's ``icidr_pde.rheology.Material()`` when that
package is importable, otherwise the paper's Table 1 values (mu_s = 0.248,
mu_d = 0.588, I0 = 0.145, phi_c = 0.817, a = 0.314), used in (2.10)-(2.11).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TABLE1 = {"mu_s": 0.248, "mu_d": 0.588, "I0": 0.145, "phi_c": 0.817, "a": 0.314}
PARAM_NAMES = ("mu_s", "mu_d", "I0", "phi_c", "a")


@dataclass(frozen=True)
class Table1Material:
    """Fallback material (Table 1) used only when ``icidr_pde`` is not importable."""

    mu_s: float = TABLE1["mu_s"]
    mu_d: float = TABLE1["mu_d"]
    I0: float = TABLE1["I0"]
    phi_c: float = TABLE1["phi_c"]
    a: float = TABLE1["a"]

    def __post_init__(self):
        for name in PARAM_NAMES:
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"`{name}` must be a finite number; got {v!r}")
        if not 0 < self.mu_s < self.mu_d < 1:
            raise ValueError(f"need 0 < mu_s < mu_d < 1; got mu_s={self.mu_s}, mu_d={self.mu_d}")
        if self.I0 <= 0:
            raise ValueError(f"`I0` must be > 0; got {self.I0}")
        if not 0 < self.phi_c < 1:
            raise ValueError(f"`phi_c` must lie in (0, 1); got {self.phi_c}")
        if self.a <= 0:
            raise ValueError(f"`a` must be > 0; got {self.a}")


def default_material():
    """``icidr_pde.rheology.Material()`` if importable, else :class:`Table1Material`."""
    try:
        from icidr_pde.rheology import Material  # noqa: PLC0415
    except Exception:  # pragma: no cover - depends on the simulator being present
        return Table1Material()
    return Material()


def material_params(material=None) -> dict:
    """Return the five parameters of `material` (default: :func:`default_material`) as floats."""
    material = default_material() if material is None else material
    return {name: float(getattr(material, name)) for name in PARAM_NAMES}


def check_phi(phi, material=None, name: str = "phi") -> np.ndarray:
    """Validate packing fractions: finite and in the inertial range (0, phi_c)."""
    phi_c = material_params(material)["phi_c"]
    arr = np.asarray(phi, dtype=float)
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0) or np.any(arr >= phi_c):
        raise ValueError(f"`{name}` must lie in (0, phi_c) = (0, {phi_c}); got {phi!r}")
    return arr


def check_rate(value, name: str) -> np.ndarray:
    """Validate a strain-rate component (u_z or w_z): any finite real number."""
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"`{name}` must be finite (any real number); got {value!r}")
    return arr


def check_xi(xi, name: str = "xi") -> float:
    """Validate a wavenumber: finite and > 0."""
    try:
        x = float(xi)
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a number in (0, inf); got {xi!r}") from None
    if not math.isfinite(x) or x <= 0:
        raise ValueError(f"`{name}` must lie in (0, inf); got {xi!r}")
    return x


def check_rheology_name(name: str) -> str:
    """Validate a rheology name: 'mui' or 'icidr'."""
    if name not in ("mui", "icidr"):
        raise ValueError(f"`rheology` must be one of ['icidr', 'mui']; got {name!r}")
    return name
