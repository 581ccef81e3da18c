"""A non-monotonic friction law (section 7.3) and the two rheologies built on it.

DeGiuli & Wyart (2017) found that mu(I) of frictional grains *decreases* at small I before
rising to the usual (2.10). The law used here adds to (2.10) a decreasing branch,

    mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1) + dmu I_m/(I + I_m),

with Table 1's mu_s, mu_d, I0 and dmu = 0.1, I_m = 0.01: mu(0) = mu_s + dmu = 0.348, a
minimum mu = 0.319 at I = 0.0124 (phi = 0.8131 with (2.13)), then mu -> mu_d. So friction
decreases with I on 0 < I < 0.0124, i.e. for 0.8131 < phi < phi_c. These values are a choice
that puts the minimum inside the inertial range where the shear cell can reach it, in the
range DeGiuli & Wyart report (minimum at I ~ 1e-3 to 1e-2, depth ~ 0.01 to 0.05); they are
not fitted to DEM data.

* ``icidr-nonmonotonic``: iCIDR (4.7)-(4.8) with this mu, through M = mu(Psi(phi)): (4.3)-(4.5)
  do not involve mu'(I) (section 7.3), so it stays well-posed;
* ``mui-nonmonotonic``: mu(I),Phi(I) with the same mu, ill-posed where friction decreases.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .icidr import ICIDR
from .laws import MuOfI
from .material import Material
from .mui import MuIPhiI

__all__ = ["NonMonotonicMu", "ICIDRNonMonotonic", "MuINonMonotonic", "NONMONOTONIC_DEFAULTS"]

NONMONOTONIC_DEFAULTS = {"delta_mu": 0.1, "I_m": 0.01}


@dataclass(frozen=True)
class NonMonotonicMu(MuOfI):
    """mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1) + delta_mu I_m/(I + I_m): (2.10) plus a term
    that gives a minimum at small I."""

    name: ClassVar[str] = "non-monotonic"
    delta_mu: float = NONMONOTONIC_DEFAULTS["delta_mu"]
    I_m: float = NONMONOTONIC_DEFAULTS["I_m"]

    def validate(self):
        super().validate()
        if not 0 <= self.delta_mu < 1 - self.mu_s:
            raise ValueError(f"`delta_mu` must lie in [0, 1 - mu_s) = [0, {1 - self.mu_s:g}) so that mu < 1; "
                             f"got {self.delta_mu}")
        if not self.I_m > 0:
            raise ValueError(f"`I_m` must be > 0; got {self.I_m}")

    def mu(self, I, prm):  # noqa: E741
        return super().mu(I, prm) + prm["delta_mu"] * prm["I_m"] / (I + prm["I_m"])


def nonmonotonic_material(**parameters) -> Material:
    return Material(friction=NonMonotonicMu.name, **parameters)


class ICIDRNonMonotonic(ICIDR):
    """iCIDR (4.7)-(4.8) with the non-monotonic mu(I) of DeGiuli & Wyart type (section 7.3)."""

    name = "icidr-nonmonotonic"
    label = r"iCIDR, non-monotonic $\mu$"

    @classmethod
    def default_material(cls):
        return nonmonotonic_material()


class MuINonMonotonic(MuIPhiI):
    """mu(I),Phi(I) with the non-monotonic mu(I): ill-posed where friction decreases."""

    name = "mui-nonmonotonic"
    label = r"$\mu(I),\Phi(I)$, non-monotonic $\mu$"

    @classmethod
    def default_material(cls):
        return nonmonotonic_material()
