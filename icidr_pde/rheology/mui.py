"""The compressible mu(I),Phi(I)-rheology (2.6)-(2.8): p from (2.14), ||tau|| = mu(I) p.

At steady state I = Psi(phi), so (2.9) with d = rho_* = 1 gives p = (2||S||/Psi)^2 (2.14),
and the alignment law (2.6) with ||tau|| = M p (2.7) gives c = ||tau||/||S|| = M p/||S||
= 4 M ||S||/Psi^2 (written without the division, so c = 0 at ||S|| = 0). In the shear cell
these are (3.6) and (3.8). The pressure does not depend on div u.
"""

from .base import Rheology

__all__ = ["MuIPhiI"]


class MuIPhiI(Rheology):
    """The compressible mu(I),Phi(I)-rheology, (2.6)-(2.8); shear cell (3.6), (3.8)."""

    name = "mui"
    label = r"$\mu(I),\Phi(I)$"

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        p = (2 * norm_S / Psi) ** 2
        c = 4 * M * norm_S / Psi**2
        return p, c
