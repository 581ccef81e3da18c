"""iCIDR with the blended pressure (7.2)-(7.3) of Chialvo et al. (2012): a CIDR law across phi_c.

**Steady pressure.** In steady simple shear (div u = 0, gamma-dot = 2||S||) the pressure is
the blend (7.2) of the inertial pressure (2.14), p_inert = (gamma-dot/Psi_+)^2, and the
intermediate-regime pressure (7.3), p_itm = alpha_itm (k/d)^(3/4) gamma-dot^(1/2)
(d = rho_* = 1):

    P(phi, gamma-dot) = p_inert p_itm/(p_inert + p_itm),   1/P = Psi_+^2/gamma-dot^2 + 1/p_itm,

with Psi_+ = max(Psi(phi), 0) (the dilatancy law :class:`LinearDilatancyToJamming`): for phi >= phi_c the inertial pressure is infinite and P = p_itm,
finite, so the law runs up to and across phi_c, where iCIDR's pressure (4.12) diverges.
Parameters: k/d = k_n = 1e4, the DEM spring constant of appendix C in the units (3.12); in
2-D the spring constant is itself a stress, so k_n plays the role of k/d. alpha_itm = 1:
an order-one coefficient chosen here (appendix C has no intermediate-regime data to fit it;
not Chialvo et al.'s fitted 3-D value). With these, p_itm = 1000 gamma-dot^(1/2) and the cap
acts where Psi^2 < gamma-dot^(3/2)/1000, i.e. within a I*a ~ 1e-3 of phi_c at gamma-dot = 1/30.
The friction coefficient is M_+ = mu(Psi_+), mu_s beyond phi_c.

**Yield and dilatancy functions.** In the variables (p, gamma-dot), gamma-dot = I sqrt(p), the
operator of (4.3) and (4.5), d/dp - (I/2p) d/dI at fixed I, is d/dp at fixed gamma-dot; (4.3)
reads dY/dp = d(gamma-dot f)/d(gamma-dot). iCIDR is f = (M/4)(sqrt(P/p) - sqrt(p/P)),
Y = M sqrt(p P) with P = (gamma-dot/Psi)^2. Keeping that f for the blended P (so (4.5) holds:
df/dp < 0 at fixed gamma-dot) and integrating (4.3) in p with (4.6) (Y = M p where p = P)
gives, with r = p/P and eps = dln P/dln gamma-dot (eps = 2 for iCIDR, where Y reduces to (4.7)):

    Y = (M P/4) [(2 + eps) r^(1/2) + ((eps - 2)/3) r^(3/2)] + M P (2 - eps)/3.

The workbench checks (4.3)-(4.5) for these (the derivation above is not trusted), and solves
the flow rule for p in closed form: sqrt(p) = sqrt(P) (R - div u)/(M ||S||), which is (4.12)
when P = p_inert.
"""

from dataclasses import dataclass
from typing import ClassVar

from .cidr import CIDRLaw
from .laws import TABLE1, DilatancyLaw, _check_phi_c
from .material import Material

__all__ = ["ICIDRBlended", "LinearDilatancyToJamming", "K_OVER_D", "ALPHA_ITM", "PHI_MAX"]

K_OVER_D = 10000      # k_n of appendix C, non-dimensional (3.12)
ALPHA_ITM = 1         # order-one coefficient of (7.3), chosen (see the module docstring)
PHI_MAX = 0.86        # the law's domain reaches beyond phi_c = 0.817 (Table 1)


@dataclass(frozen=True)
class LinearDilatancyToJamming(DilatancyLaw):
    """(2.11) below phi_c, continued by Psi_+ = max((phi_c - phi)/a, 0) up to phi_max.

    Psi_+^2 is C^1 at phi_c; M = mu(Psi_+) = mu_s beyond phi_c (only Lipschitz there).
    """

    name: ClassVar[str] = "linear-to-jamming"
    phi_c: float = TABLE1["phi_c"]
    a: float = TABLE1["a"]
    phi_max: float = PHI_MAX

    def validate(self):
        _check_phi_c(self.phi_c)
        if not self.a > 0:
            raise ValueError(f"`a` must be > 0; got {self.a}")
        if not self.phi_c < self.phi_max <= 1:
            raise ValueError(f"`phi_max` must lie in (phi_c, 1] = ({self.phi_c}, 1]; got {self.phi_max}")

    def Phi(self, I, prm):  # noqa: E741
        return prm["phi_c"] - prm["a"] * I

    def Psi(self, phi, prm):
        import sympy as sp

        psi = (prm["phi_c"] - phi) / prm["a"]
        return sp.Piecewise((psi, phi < prm["phi_c"]), (0, True))

    def phi_range(self):
        return 0.0, self.phi_max

    def range_names(self):
        return "0", "phi_max"


def steady_pressure(gamma_dot, Psi):
    """P(phi, gamma-dot) of (7.2)-(7.3): 1/P = Psi_+^2/gamma-dot^2 + 1/p_itm."""
    import sympy as sp

    p_itm = ALPHA_ITM * sp.Integer(K_OVER_D) ** sp.Rational(3, 4) * sp.sqrt(gamma_dot)
    return gamma_dot**2 * p_itm / (gamma_dot**2 + Psi**2 * p_itm)


class ICIDRBlended(CIDRLaw):
    """iCIDR generalised to the blended steady pressure (7.2)-(7.3) (Chialvo et al. 2012)."""

    name = "icidr-blended"
    label = "iCIDR, blended pressure (7.2)"

    @classmethod
    def default_material(cls):
        return Material(dilatancy=LinearDilatancyToJamming.name)

    def _parts(self, p, I, Psi):  # noqa: E741
        import sympy as sp

        g = sp.Symbol("gamma_dot", positive=True)
        P = steady_pressure(g, Psi)
        eps = sp.simplify(g * sp.diff(P, g) / P)
        at = {g: I * sp.sqrt(p)}
        return P.xreplace(at), eps.xreplace(at)

    def closed_form(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        """sqrt(p) = 2 k G/M, c = Y/||S||, written without 0/0 as ||S|| -> 0 (checked by the workbench).

        gamma-dot = 2||S||, G = R - div u (4.12), p_itm = beta gamma-dot^(1/2) with
        beta = alpha_itm (k/d)^(3/4), k = sqrt(beta/(beta Psi^2 + gamma-dot^(3/2))) = sqrt(P)/gamma-dot,
        omega = P/p_itm = gamma-dot^(3/2)/(gamma-dot^(3/2) + beta Psi^2), so eps = 2 - 3 omega/2.
        """
        import sympy as sp

        from .icidr import gap

        beta = ALPHA_ITM * sp.Integer(K_OVER_D) ** sp.Rational(3, 4)
        g32 = (2 * norm_S) ** sp.Rational(3, 2)
        k = sp.sqrt(beta / (beta * Psi**2 + g32))
        omega = g32 / (g32 + beta * Psi**2)
        q = 2 * k * gap(div_u, norm_S, M, stable) / M
        p_itm = beta * sp.sqrt(2 * norm_S)
        c = M / 2 * (4 - sp.Rational(3, 2) * omega) * k * q - M / 4 * k * q**3 / p_itm + 2 * M * k**2 * norm_S * omega
        return q**2, c

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, eps = self._parts(p, I, Psi)
        r = p / P
        return M * P / 4 * ((2 + eps) * sp.sqrt(r) + (eps - 2) / 3 * r ** sp.Rational(3, 2)) + M * P * (2 - eps) / 3

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, _ = self._parts(p, I, Psi)
        return M / 4 * (sp.sqrt(P / p) - sp.sqrt(p / P))
