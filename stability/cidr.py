"""CIDR framework of section 4: well-posedness conditions and the iCIDR functions.

* (4.1)-(4.2): ||tau|| = Y(p, I, phi), div u = 2 f(p, I, phi) ||S||.
* (4.3)-(4.5): Barker et al. (2017) conditions, for arbitrary Y and f
  (:func:`condition_43`, :func:`condition_44`, :func:`condition_45`).
* (4.6) -- lost in the transcription, reconstructed from the text: the steady
  isochoric (div u = 0) flows must reproduce mu(I),Phi(I), i.e. at I = Psi(phi)
  ``Y = mu(Psi(phi)) p`` and ``f = 0`` (:func:`steady_isochoric_relations`).
* (4.7): the iCIDR yield function; (4.8) is *derived* here by solving the linear ODE
  (4.3) in I for f and imposing (4.6) (:func:`derive_dilatancy`).
* (4.9)-(4.14): inertial number, pressure and deviatoric stress of iCIDR.

All identities use the generic functions M(phi) = mu(Psi(phi)) and Psi(phi), so they
hold for any positive M and Psi, not only for (2.10)-(2.13).
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from .checks import EXACT, FAILS, Check, compare, exact_zero
from .symbols import I, Mf, Psif, Sn, d, delta, p, phi, rho

SECTION = "4 CIDR"


def _MP():
    return Mf(phi), Psif(phi)


# --- the three conditions (4.3)-(4.5) for arbitrary Y, f -----------------------------

def condition_43(Y, f):
    """(4.3) residual: dY/dp - I/(2p) dY/dI - (f + I df/dI); must vanish identically."""
    return sp.diff(Y, p) - I / (2 * p) * sp.diff(Y, I) - (f + I * sp.diff(f, I))


def condition_44(Y):
    """(4.4) quantity dY/dI; must be > 0."""
    return sp.diff(Y, I)


def condition_45(f):
    """(4.5) quantity df/dp - I/(2p) df/dI; must be < 0."""
    return sp.diff(f, p) - I / (2 * p) * sp.diff(f, I)


def steady_isochoric_relations(Y, f):
    """Reconstructed (4.6): residuals (Y - mu(Psi(phi)) p, f) at I = Psi(phi); both must be 0."""
    M, Psi = _MP()
    return sp.simplify((Y - M * p).subs(I, Psi)), sp.simplify(f.subs(I, Psi))


# --- yield functions ----------------------------------------------------------------

def yield_rate_independent():
    """The starting point Y = mu(Psi(phi)) p of section 4 (satisfies (4.6), violates (4.4))."""
    M, _ = _MP()
    return M * p


def yield_icidr():
    """iCIDR yield function (4.7): Y = mu(Psi(phi)) (I/Psi(phi)) p (a modelling choice)."""
    M, Psi = _MP()
    return M * I / Psi * p


def derive_dilatancy(Y):
    """Solve (4.3) for f given Y and impose f(I = Psi(phi)) = 0 from (4.6).

    (4.3) reads d(I f)/dI = dY/dp - I/(2p) dY/dI, a linear first-order ODE in I with
    (p, phi) as parameters; its general solution is particular + c(p, phi)/I, and
    (4.6) fixes c.  Returns the derived f (for (4.7) this is (4.8)).
    """
    _, Psi = _MP()
    g = sp.Function("g")
    rhs = sp.diff(Y, p) - I / (2 * p) * sp.diff(Y, I)
    sol = sp.dsolve(sp.Eq(g(I) + I * g(I).diff(I), rhs), g(I)).rhs
    consts = [s for s in sol.free_symbols if s.name.startswith("C")]
    (C1,) = consts
    c_val = sp.solve(sp.Eq(sol.subs(I, Psi), 0), C1)[0]
    return sp.simplify(sol.subs(C1, c_val))


@lru_cache(maxsize=None)
def dilatancy_icidr():
    """The iCIDR dilatancy function (4.8), derived by :func:`derive_dilatancy`."""
    return derive_dilatancy(yield_icidr())


# --- iCIDR inertial number, pressure and stress ---------------------------------------

def inertial_number_definition():
    """(2.9): I = 2 d ||S|| / sqrt(p/rho_*)."""
    return 2 * d * Sn / sp.sqrt(p / rho)


@lru_cache(maxsize=None)
def icidr_inertial_number():
    """Positive root I of the flow rule (4.2) with (4.8), as a function of div u, ||S|| ((4.10))."""
    f = dilatancy_icidr()
    roots = sp.solve(sp.Eq(delta, 2 * f * Sn), I)
    # the positive root: the one that is positive at a sample point (delta = 0 gives Psi)
    M, Psi = _MP()
    pos = [r for r in roots if sp.simplify(r.subs(delta, 0) - Psi) == 0]
    return sp.simplify(pos[0])


def icidr_sqrt_pressure(div, normS, M=None, Psi=None):
    """sqrt of (4.12): sqrt(rho_*) 2d/(M Psi) [sqrt(div^2 + M^2 ||S||^2) - div] (>= 0)."""
    if M is None or Psi is None:
        M, Psi = _MP()
    return sp.sqrt(rho) * 2 * d / (M * Psi) * (sp.sqrt(div**2 + M**2 * normS**2) - div)


def icidr_pressure(div, normS, M=None, Psi=None):
    """(4.12) pressure of iCIDR, defined for every deformation rate (verified in :func:`checks`)."""
    return icidr_sqrt_pressure(div, normS, M, Psi) ** 2


def icidr_deviatoric_stress(S, sqrt_p, M=None, Psi=None):
    """(4.14): tau_ij = 2 d sqrt(rho_*) M/Psi sqrt(p) S_ij (verified in :func:`checks`)."""
    if M is None or Psi is None:
        M, Psi = _MP()
    return 2 * d * sp.sqrt(rho) * M / Psi * sqrt_p * S


# --- verification ---------------------------------------------------------------------

def checks() -> list[Check]:
    """Verify (4.3)-(4.14) (and the reconstructed (4.6)); see module docstring."""
    M, Psi = _MP()
    out = []
    sec = SECTION

    # Y = mu(Psi) p: satisfies (4.6) but violates (4.4)
    Y0 = yield_rate_independent()
    r44 = condition_44(Y0)
    out.append(Check("(4.4) Y = mu p", "Y = mu(Psi(phi)) p violates (4.4) (dY/dI = 0, not > 0)",
                     EXACT if r44 == 0 else FAILS, f"dY/dI = {r44}", section=sec))
    f0 = derive_dilatancy(Y0)
    out.append(Check("(4.3) Y = mu p", "for Y = mu(Psi) p, (4.3)+(4.6) would force f = M (1 - Psi/I)",
                     EXACT if exact_zero(condition_43(Y0, f0)) and exact_zero(f0 - M * (1 - Psi / I)) else FAILS,
                     f"f = {sp.sstr(f0)} (only (4.4) fails; (4.5) holds)", section=sec))

    Y = yield_icidr()
    res6 = steady_isochoric_relations(Y, 0 * p)
    out.append(Check("(4.7)", "iCIDR yield function reduces to mu(I) p at I = Psi(phi) (first half of (4.6))",
                     EXACT if res6[0] == 0 else FAILS, "Y(p, Psi(phi), phi) - mu(Psi(phi)) p = 0", section=sec))

    f = dilatancy_icidr()
    printed48 = sp.Rational(1, 4) * M * (I / Psi - Psi / I)
    c = compare("(4.8)", "dilatancy function: solve (4.3) (homogeneous + particular) and impose (4.6)",
                f, printed48, section=sec)
    c.detail = f"derived f = {sp.sstr(f)}; " + c.detail
    out.append(c)

    ok43 = exact_zero(condition_43(Y, f))
    r6 = steady_isochoric_relations(Y, f)
    zeros = sp.solve(sp.Eq(f, 0), I)  # I is a positive symbol: positive roots only
    out.append(Check("(4.6)", "reconstructed (4.6): at div u = 0 (f = 0) I = Psi(phi) and Y = mu(Psi(phi)) p; "
                     "(4.7)-(4.8) satisfy (4.3) and (4.6)",
                     EXACT if ok43 and r6 == (0, 0) and zeros == [Psif(phi)] else FAILS,
                     "(4.3) residual = 0; f(I = Psi) = 0; Y(I = Psi) = M p; f = 0 has the unique positive root I = Psi",
                     section=sec))

    q44 = sp.simplify(condition_44(Y))
    out.append(Check("(4.4)", "iCIDR: dY/dI = M p / Psi > 0",
                     EXACT if exact_zero(q44 - M * p / Psi) and q44.is_positive else FAILS,
                     f"dY/dI = {sp.sstr(q44)}, positive for M, Psi, p > 0 (phi < phi_c)", section=sec))
    q45 = sp.simplify(condition_45(f))
    target45 = -M / (8 * p) * (I / Psi + Psi / I)
    out.append(Check("(4.5)", "iCIDR: df/dp - I/(2p) df/dI = -(M/(8p)) (I/Psi + Psi/I) < 0",
                     EXACT if exact_zero(q45 - target45) and q45.is_negative else FAILS,
                     f"= {sp.sstr(q45)}", section=sec))

    # (4.9): flow rule (4.2) with (4.8) multiplied by 2 I Psi/(M ||S||) > 0
    printed49 = I**2 - 2 * Psi * delta / (M * Sn) * I - Psi**2
    flow = delta - 2 * f * Sn
    ok49 = exact_zero(printed49 + 2 * I * Psi / (M * Sn) * flow)
    out.append(Check("(4.9)", "flow rule (4.2) with (4.8) is equivalent to the quadratic (4.9)",
                     EXACT if ok49 else FAILS, "(4.9) = -(2 I Psi/(M ||S||)) (div u - 2 f ||S||)", section=sec))

    Iroot = icidr_inertial_number()
    X = Psi * delta / (M * Sn)
    out.append(compare("(4.10)", "positive root of (4.9)", Iroot, X + sp.sqrt(X**2 + Psi**2), section=sec))

    (p_of_I,) = sp.solve(sp.Eq(I, inertial_number_definition()), p)
    out.append(compare("(4.11)", "pressure from the inertial number (2.9)", p_of_I,
                       rho * (2 * d * Sn / I) ** 2, section=sec))

    p_route = p_of_I.subs(I, Iroot)
    p412 = icidr_pressure(delta, Sn)
    c = compare("(4.12)", "pressure free of I: (4.11) with (4.10), rationalised", p_route, p412, section=sec)
    out.append(c)
    R = sp.sqrt(delta**2 + M**2 * Sn**2)
    nonneg = exact_zero((R - delta) * (R + delta) - M**2 * Sn**2)
    out.append(Check("(4.12) well-defined", "well defined for all deformation rates: radicand div^2 + M^2||S||^2 >= 0, "
                     "no division by ||S|| or I; sqrt(p) = sqrt(rho)2d/(M Psi)(R - div) with R - div >= 0",
                     EXACT if nonneg else FAILS,
                     "(R - div)(R + div) = M^2 ||S||^2 >= 0 and R >= |div|, so R - div >= 0; "
                     "p is continuous in (div u, S) including ||S|| = 0", section=sec))

    dpos, dneg = sp.Symbol("dpos", positive=True), sp.Symbol("dneg", negative=True)
    at0 = p412.subs(Sn, 0)
    z_pos = sp.simplify(at0.subs(delta, dpos))
    z_neg = sp.simplify(at0.subs(delta, dneg))
    z_zero = sp.simplify(at0.subs(delta, 0))
    ok413 = z_pos == 0 and z_zero == 0 and z_neg.is_positive and nonneg
    out.append(Check("(4.13)", "p = 0 iff ||S|| = 0 and div u >= 0; p > 0 (finite) if ||S|| = 0, div u < 0",
                     EXACT if ok413 else FAILS,
                     f"||S||=0: div>0 -> p = {z_pos}, div=0 -> {z_zero}, div<0 -> p = {sp.sstr(z_neg)}; "
                     "||S||>0 -> R > |div| -> p > 0", section=sec))

    # (4.14): alignment (2.6) with ||tau|| = Y (4.1), (4.7), I from (2.9)
    Sij = sp.Symbol("S_ij", real=True)
    tau_route = Y.subs(I, inertial_number_definition()) * Sij / Sn
    printed414 = 2 * d * sp.sqrt(rho) * M / Psi * sp.sqrt(p) * Sij
    out.append(compare("(4.14)", "deviatoric stress tau = Y S/||S|| with (4.7) and (2.9)", tau_route,
                       printed414, section=sec))
    return out
