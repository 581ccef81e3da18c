"""The compressible mu(I),Phi(I)-rheology (2.6)-(2.8): p from (2.14), ||tau|| = mu(I) p.

A law given directly as p and ||tau|| (:class:`~.direct.DirectLaw`): phi = Phi(I) (2.8) is not
a flow rule (4.2), so (4.3)-(4.5) do not apply; only the stability analysis does.
At steady state I = Psi(phi), so (2.9) with d = rho_* = 1 gives p = (2||S||/Psi)^2 (2.14),
and the alignment law (2.6) with ||tau|| = M p (2.7) gives c = ||tau||/||S|| = M p/||S||
= 4 M ||S||/Psi^2 (the division cancels, so c = 0 at ||S|| = 0). In the shear cell
these are (3.6) and (3.8). The pressure does not depend on div u.
"""

from .direct import DirectLaw

__all__ = ["MuIPhiI"]


class MuIPhiI(DirectLaw):
    """The compressible mu(I),Phi(I)-rheology, (2.6)-(2.8); shear cell (3.6), (3.8)."""

    name = "mui"
    rate_homogeneous = True  # p, tau of degree 2 in the strain rate: I is rate-independent
    label = r"$\mu(I),\Phi(I)$"

    def pressure(self, phi, div_u, norm_S, M, Psi, prm):
        return (2 * norm_S / Psi) ** 2                           # (2.14)

    def shear_stress(self, phi, div_u, norm_S, M, Psi, prm):
        return M * self.pressure(phi, div_u, norm_S, M, Psi, prm)   # (2.7) at I = Psi(phi)
