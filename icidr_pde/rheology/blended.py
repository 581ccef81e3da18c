"""iCIDR with the blended pressure (7.2)-(7.3) of Chialvo et al. (2012): CIDR laws across phi_c.

**Steady pressure.** In steady simple shear (div u = 0, gamma-dot = 2||S||) the pressure is
the blend (7.2) of the inertial pressure (2.14), p_inert = (gamma-dot/Psi_+)^2, and the
intermediate-regime pressure (7.3), p_itm = alpha_itm (k/d)^(3/4) gamma-dot^(1/2)
(d = rho_* = 1):

    P(phi, gamma-dot) = p_inert p_itm/(p_inert + p_itm),   1/P = Psi_+^2/gamma-dot^2 + 1/p_itm,

with Psi_+ = max(Psi(phi), 0) (the dilatancy law :class:`LinearDilatancyToJamming`): for
phi >= phi_c the inertial pressure is infinite and P = p_itm, finite, so the laws run up to
and across phi_c, where iCIDR's pressure (4.12) diverges. The friction coefficient is
M_+ = mu(Psi_+), mu_s beyond phi_c.

**Parameters.** k/d = k_n = 1e4: the normal spring constant of the DEM of appendix C in the
units (3.12); in 2-D a spring constant is a force per length, i.e. a stress, so k_n is the
stiffness k/d of (7.3) non-dimensionalised by rho_* d^2 gamma-dot-scale^2 as every stress
here. alpha_itm = 1: an order-one coefficient chosen here, because appendix C has no
intermediate-regime (soft-particle) data to fit it and Chialvo et al.'s fitted value belongs
to their 3-D spheres and their definition of the stiffness, not to these 2-D disks. With these,
p_itm = 1000 gamma-dot^(1/2) and the cap acts where Psi^2 < gamma-dot^(3/2)/1000, i.e.
within I*a ~ 1e-3 of phi_c at gamma-dot = 1/30.

**Yield and dilatancy functions.** In the variables (p, gamma-dot), gamma-dot = I sqrt(p), the
operator of (4.3) and (4.5), d/dp - (I/2p) d/dI at fixed I, is d/dp at fixed gamma-dot; (4.3)
reads dY/dp = d(gamma-dot f)/d(gamma-dot). With r = p/P and eps = dln P/dln gamma-dot (eps = 2
where P = p_inert, 1/2 where P = p_itm), a dilatancy function f = (M/4)(r^(-1/2) - r^b)
vanishes at the steady state r = 1 and satisfies (4.5) (df/dp < 0 at fixed gamma-dot);
integrating (4.3) in p from r = 1 with (4.6) (Y = M P there) gives

    Y = M P + (M P/4) [(2 + eps)(r^(1/2) - 1) - ((1 - b eps)/(1 + b)) (r^(1 + b) - 1)].

* ``icidr-blended-half`` (:class:`ICIDRBlendedHalf`), b = 1/2: iCIDR's own dilatancy shape kept for the
  blended P, Y = (M P/4)[(2 + eps) r^(1/2) + ((eps - 2)/3) r^(3/2)] + M P (2 - eps)/3 (eps = 2
  gives (4.7)), with the closed form sqrt(p) = sqrt(P) (R - div u)/(M ||S||) ((4.12) when
  P = p_inert). (4.4) fails under strong compaction (p >> P; p >= 1e3 on the sample).
* ``icidr-blended-quarter`` (:class:`ICIDRBlendedQuarter`), b = 1/4: (4.3)-(4.5) hold (the
  workbench proves them symbolically), the 1-D symbol is well-posed. Its flow rule is the cubic
  x^3 + k x^2 - 1 = 0 in x = r^(1/4), k = 2 div u/(M ||S||): exactly one positive root (the
  left side increases for x > 0 from -1), but Cardano's formula for it needs complex arithmetic
  where the cubic has three real roots (discriminant 4 k^3 - 27 > 0, strong dilation), so p
  comes from the workbench's scalar solve (``equation_of_state = "scalar"``, :mod:`.implicit`).
  Its yield function is *negative* under strong compaction: Y ~ -(M/5)(1 - eps/4) p^(5/4) P^(-1/4)
  as r -> oo, so c = Y/||S|| < 0 there and 2-D plane waves grow without bound (the (c/2) I
  part of the 2-D symbol): ill-posed in 2-D where r is large. It does not reduce to iCIDR
  where P = p_inert (b = 1/4 is not iCIDR's 1/2).

**Why b = 1/4.** Under strong compaction (r >> 1) Y is dominated by -(M/4)((1 - b eps)/(1 + b))
p^(1+b) P^(-b), and its derivative in gamma-dot at fixed p (the sign of dY/dI) has the sign of
eps (1 - b eps) + gamma-dot d eps/d gamma-dot. With omega = P/p_itm in [0, 1], eps = 2 - 3 omega/2
and gamma-dot d eps/d gamma-dot = -(9/4) omega (1 - omega). For b = 1/2 the sum is
(9/8) omega (omega - 2/3) < 0 wherever omega < 2/3 (the failure above); for b = 1/4 it is
1 - (9/4) omega + (27/16) omega^2, positive for every omega (discriminant 81/16 - 27/4 < 0).

**Why no law of this family is well-posed.** The same leading term decides the sign of Y:
Y > 0 for r >> 1 needs 1 - b eps <= 0, and then eps (1 - b eps) + gamma-dot d eps/d gamma-dot
<= -(9/4) omega (1 - omega) < 0 wherever the blend is active (0 < omega < 1): for every
constant b > 0, f = (M/4)(r^(-1/2) - r^b) gives either Y < 0 (b < 1/eps) or (4.4) failing
(b >= 1/eps) under strong compaction. iCIDR escapes only because eps = 2 is constant there
(b = 1/2, leading coefficient 0). Neither law of this family is well-posed; the reports say where
each fails.

**The well-posed law** ``icidr-blended`` (:class:`ICIDRBlended`). Write f = c (r^(-1/2) - r^b) with
c = C P^b/gamma-dot and C independent of gamma-dot: then d(gamma-dot f)/d(gamma-dot) at fixed p has no
r^b part, and (4.3) integrated from r = 1 with (4.6) gives Y = (M - K) P + K sqrt(p P),
K = 2 eps c (b + 1/2), with no r^(1+b) term at all -- the term whose sign and gamma-dot slope
could not both be right above. This Y is linear in sqrt(p) with coefficients of fixed sign iff

    0 < K <= M   (Y > 0),   dK/dln gamma-dot >= -eps K/2   and   dK/dln gamma-dot <= (M - K) eps   ((4.4)),

and (4.5) holds for any c > 0. (4.3) is linear in (Y, f) for fixed M, so two such pieces add. One
piece alone cannot serve both regimes: K stays bounded as gamma-dot -> 0 with P = p_inert only if
b >= 1/2 and as gamma-dot -> oo with P = p_itm only if b <= 2, and b = 1/2 breaks the second condition
where P = p_itm (K ~ gamma-dot^(-3/4)). So

    c1 = (M/4) Psi_+ sqrt(P)/gamma-dot = (M/4) sqrt(1 - omega)  (b = 1/2: iCIDR's (4.8) where omega -> 0),
    c2 = kappa M omega^2 = kappa M P^2/(p_itm^2)                 (b = 2, vanishing as omega^2 where omega -> 0),

giving K = M eps [sqrt(1 - omega)/2 + 5 kappa omega^2] with omega = P/p_itm in [0, 1] and
dln omega/dln gamma-dot = (3/2)(1 - omega). On omega in [0, 1] the three conditions hold for
0.09 <= kappa <= 0.29; kappa = 1/5 is chosen where both margins are comparable (dK/dln gamma-dot +
eps K/2 >= 0.15 K, (M - K) eps - dK/dln gamma-dot >= 0.25 M omega). Beyond phi_c (omega = 1):
f = (M/5)(r^(-1/2) - r^2), Y = (M/2)(P + sqrt(p P)). The flow rule is a quintic in x = sqrt(r),
2||S|| [c1 (1 - x^2) + c2 (1 - x^5)] = div u x, with exactly one positive root (the left side minus
the right decreases from 2||S||(c1 + c2) > 0 to -oo); p comes from the scalar solve. The workbench
proves (4.3) and (4.5) symbolically and samples (4.4) and Y > 0; tests check them on
gamma-dot in [1e-8, 1e8], r in [1e-12, 1e12]. As omega -> 0 it is iCIDR: (p, c) differ by O(omega)
at fixed div u/||S|| (4e-4 in the shear cell at phi0 = 0.78); at fixed div u > 0 with p -> 0,
Y -> (M - K) P = O(omega) P where iCIDR's Y -> 0.
"""

from dataclasses import dataclass
from typing import ClassVar

from .cidr import CIDRLaw
from .laws import TABLE1, DilatancyLaw, _check_phi_c
from .material import Material

__all__ = ["ICIDRBlended", "ICIDRBlendedHalf", "ICIDRBlendedQuarter", "KAPPA", "LinearDilatancyToJamming", "K_OVER_D", "ALPHA_ITM", "PHI_MAX"]

K_OVER_D = 10000      # k_n of appendix C, non-dimensional (3.12): the DEM's own stiffness
ALPHA_ITM = 1         # order-one coefficient of (7.3): no intermediate-regime data to fit (module docstring)
PHI_MAX = 0.86        # the law's domain reaches beyond phi_c = 0.817 (Table 1)
KAPPA = 1 / 5         # weight of the intermediate-regime dilatancy of icidr-blended (module docstring)


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


class _Blended(CIDRLaw):
    """Shared parts: the material (Psi_+ across phi_c) and the steady pressure P with eps = dln P/dln gamma-dot."""

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


class ICIDRBlendedQuarter(_Blended):
    """The blended steady pressure with f = (M/4)(r^(-1/2) - r^(1/4)), r = p/P: (4.3)-(4.5) hold, Y < 0 for r >> 1."""

    name = "icidr-blended-quarter"
    label = "blended pressure (7.2), quarter-power dilatancy"
    equation_of_state = "scalar"   # the cubic flow rule's real root needs complex arithmetic in closed form

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, eps = self._parts(p, I, Psi)
        r = p / P
        b = sp.Rational(1, 4)
        return M * P + M * P / 4 * ((2 + eps) * (sp.sqrt(r) - 1) - (1 - b * eps) / (1 + b) * (r ** (1 + b) - 1))

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, _ = self._parts(p, I, Psi)
        return M / 4 * (sp.sqrt(P / p) - (p / P) ** sp.Rational(1, 4))


class ICIDRBlendedHalf(_Blended):
    """iCIDR's dilatancy shape kept for the blended steady pressure (7.2)-(7.3): (4.4) fails under strong compaction."""

    name = "icidr-blended-half"
    label = "blended pressure (7.2), iCIDR's dilatancy shape"

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


class ICIDRBlended(_Blended):
    """The blended steady pressure (7.2)-(7.3) as a well-posed CIDR law that is iCIDR where P = p_inert.

    f = M [(1/4) sqrt(1 - omega) (r^(-1/2) - r^(1/2)) + kappa omega^2 (r^(-1/2) - r^2)],
    Y = (M - K) P + K sqrt(p P),   K = M eps [sqrt(1 - omega)/2 + 5 kappa omega^2],

    r = p/P, omega = P/p_itm, eps = 2 - 3 omega/2, kappa = 1/5 (module docstring).
    """

    name = "icidr-blended"
    label = "blended pressure (7.2), well-posed two-regime dilatancy"
    equation_of_state = "scalar"   # the flow rule is a quintic in sqrt(r)

    def _regimes(self, p, I, Psi):  # noqa: E741
        """(P, eps, omega, sqrt(1 - omega)) at gamma-dot = I sqrt(p); sqrt(1 - omega) = Psi sqrt(P)/gamma-dot."""
        import sympy as sp

        P, eps = self._parts(p, I, Psi)
        g = I * sp.sqrt(p)
        p_itm = ALPHA_ITM * sp.Integer(K_OVER_D) ** sp.Rational(3, 4) * sp.sqrt(g)
        omega = g**2 / (g**2 + Psi**2 * p_itm)
        inertial = Psi * sp.sqrt(p_itm) / sp.sqrt(g**2 + Psi**2 * p_itm)
        return P, eps, omega, inertial

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, eps, omega, inertial = self._regimes(p, I, Psi)
        K = M * eps * (inertial / 2 + 5 * sp.nsimplify(KAPPA) * omega**2)
        return (M - K) * P + K * sp.sqrt(p * P)

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        import sympy as sp

        P, _, omega, inertial = self._regimes(p, I, Psi)
        r = p / P
        return M * (inertial / 4 * (1 / sp.sqrt(r) - sp.sqrt(r)) + sp.nsimplify(KAPPA) * omega**2 * (1 / sp.sqrt(r) - r**2))
