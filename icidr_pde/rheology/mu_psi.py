"""The rate-independent yield function Y = mu(Psi(phi)) p: the starting point section 4 rejects.

Y = M p satisfies the steady relations (4.6) but dY/dI = 0, so (4.4) fails. The dilatancy
function is the one (4.3) with (4.6) then forces, f = M (1 - Psi/I) (derived by
``stability.cidr.derive_dilatancy``; the workbench checks (4.3) for it). The flow rule gives
sqrt(p) = (2 ||S|| - div u/M)/Psi, positive only where div u < 2 M ||S||: elsewhere there
is no positive pressure, so this law is for the stability analysis only.
"""

from .cidr import CIDRLaw

__all__ = ["MuPsi"]


class MuPsi(CIDRLaw):
    """Y = mu(Psi(phi)) p with f = M (1 - Psi/I): violates (4.4) (section 4)."""

    name = "mu-psi"
    label = r"$Y = \mu(\Psi(\phi))\,p$"

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        return M * p

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        return M * (1 - Psi / I)
