"""iCIDR and mu(I),Phi(I) with section 2's saturating Phi(I) (:class:`~.laws.SaturatingDilatancy`).

Phi(I) = phi_c - (phi_c - phi_min)/(I_*/I + 1) stays above phi_min for every I; its inverse
Psi(phi) = I_* (phi_c - phi)/(phi - phi_min) enters both laws only through M = mu(Psi) and Psi,
so iCIDR's conditions (4.3)-(4.5), proved for any M, Psi > 0, hold unchanged.
"""

from .icidr import ICIDR
from .material import Material
from .mui import MuIPhiI

__all__ = ["ICIDRSaturating", "MuISaturating"]


class ICIDRSaturating(ICIDR):
    """iCIDR (4.7)-(4.8) with the saturating Phi(I) of section 2."""

    name = "icidr-saturating-phi"
    label = r"iCIDR, saturating $\Phi$"

    @classmethod
    def default_material(cls):
        return Material(dilatancy="saturating")


class MuISaturating(MuIPhiI):
    """mu(I),Phi(I) with the saturating Phi(I) of section 2."""

    name = "mui-saturating-phi"
    label = r"$\mu(I),\Phi(I)$, saturating $\Phi$"

    @classmethod
    def default_material(cls):
        return Material(dilatancy="saturating")
