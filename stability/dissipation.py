"""Appendix B: positive stress power, the potentials (B8)-(B13), psi = D/3 and convexity.

Symbols: a general 2-D symmetric strain rate D = [[A, B], [B, C]] (div u = A + C),
deviatoric part S (2.5), pressure p, ||T|| = sqrt(tr(T T^T)/2).  Everything is built
from the iCIDR relations (4.7), (4.8), (4.12), (4.14) of :mod:`stability.cidr`.
The paper assumes, without direct proof, that psi is convex; :func:`convexity_sample`
checks that numerically (Hessian of psi(D) positive semi-definite) and the shear-cell
restriction is proved in :mod:`stability.icidr` (Hessian = phi Gamma).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

from . import cidr, rheologies
from .checks import EXACT, FAILS, NUMERIC, Check, compare, exact_zero, numeric_zero
from .symbols import I, M, Psi, Sn, d, delta, p, phi, rho, uz, wz

SECTION = "B dissipation"

A_, B_, C_ = sp.symbols("A B C", real=True)


def norm(T):
    """||T|| = sqrt(tr(T T^T)/2) (= sqrt(tr(T^2)/2) for symmetric T)."""
    return sp.sqrt((T * T.T).trace() / 2)


def general_strain():
    """D, div u, S for the general 2-D symmetric strain rate [[A, B], [B, C]]."""
    D = sp.Matrix([[A_, B_], [B_, C_]])
    div = D.trace()
    S = D - div / 2 * sp.eye(2)
    return D, div, S


@lru_cache(maxsize=None)
def psi_of_D():
    """psi(D) of (B12)/(B13) with p = P(S, div u) from (4.12), M, Psi as symbols, d = rho = 1."""
    D, div, S = general_strain()
    nS2 = sp.expand((S * S).trace() / 2)
    sqrtP = cidr.icidr_sqrt_pressure(div, sp.sqrt(nS2), M, Psi).subs({d: 1, rho: 1})
    return M / Psi * nS2 * sqrtP + M * Psi / 12 * sqrtP**3, sqrtP, S, D


def checks() -> list[Check]:
    """Verify (B2)-(B15)."""
    sec = SECTION
    out = []
    s1, s2, t1, t2 = sp.symbols("s1 s2 t1 t2", real=True)
    S = sp.Matrix([[s1, s2], [s2, -s1]])
    tau = sp.Matrix([[t1, t2], [t2, -t1]])
    Dm = S + delta / 2 * sp.eye(2)
    sigma = -p * sp.eye(2) + tau
    ok2a = exact_zero(norm(Dm) ** 2 - (norm(S) ** 2 + delta**2 / 4))
    ok2b = exact_zero(norm(sigma) ** 2 - (norm(tau) ** 2 + p**2))
    out.append(Check("(B2)", "||D||^2 = ||S||^2 + (div u)^2/4, ||sigma||^2 = ||tau||^2 + p^2",
                     EXACT if ok2a and ok2b else FAILS, "", section=sec))
    ok3 = exact_zero((sigma * Dm).trace() - ((tau * S).trace() - p * delta))
    out.append(Check("(B3)", "D = tr(sigma D) = tr(tau S) - p div u", EXACT if ok3 else FAILS, "", section=sec))

    Tn = sp.Symbol("T_n", positive=True)       # ||tau||
    f = sp.Symbol("f", real=True)
    tau_al = Tn * S / norm(S)                  # alignment (2.6)
    D4 = (tau_al * S).trace() - p * (2 * f * norm(S))
    ok4 = exact_zero(D4 - (2 * Tn * norm(S) - 2 * f * norm(S) * p))
    out.append(Check("(B4)", "with (2.6) and (4.2): D = 2||tau|| ||S|| - 2 f ||S|| p", EXACT if ok4 else FAILS,
                     "", section=sec))

    Mf_, Pf_ = cidr.Mf(phi), cidr.Psif(phi)
    Y = cidr.yield_icidr()
    fI = cidr.dilatancy_icidr()
    D5 = 2 * Y * Sn - 2 * fI * Sn * p
    out.append(compare("(B5)", "with (4.1), (4.7), (4.8): D = M||S||[3I/(2Psi) + Psi/(2I)] p", D5,
                       Mf_ * Sn * (sp.Rational(3, 2) * I / Pf_ + Pf_ / (2 * I)) * p, section=sec))
    Idef = cidr.inertial_number_definition()
    D6 = D5.subs(I, Idef)
    printed6 = 3 * d * Mf_ * sp.sqrt(rho) / Pf_ * Sn**2 * sp.sqrt(p) + Mf_ * Pf_ / (4 * d * sp.sqrt(rho)) * p ** sp.Rational(3, 2)
    out.append(compare("(B6)", "D = 3 d M sqrt(rho)/Psi ||S||^2 sqrt(p) + M Psi/(4 d sqrt(rho)) p^{3/2}", D6, printed6,
                       section=sec))
    # (B1): positivity, including ||S|| = 0 via (4.13)
    P0neg = cidr.icidr_pressure(sp.Symbol("dn", negative=True), 0)
    okB1 = P0neg.is_positive and cidr.icidr_pressure(sp.Symbol("dp", positive=True), 0) == 0
    out.append(Check("(B1)", "D > 0 whenever ||D|| > 0 and ||sigma|| > 0 (iCIDR)", EXACT if okB1 else FAILS,
                     "both terms of (B6) are >= 0 and the first is > 0 if ||S|| > 0; if ||S|| = 0, div u < 0 then "
                     "p > 0 by (4.12) so the second is > 0; if ||S|| = 0, div u >= 0 then p = 0 and tau = 0 (4.14)",
                     section=sec))

    # (B8)-(B11) with independent components S_ij (||S||^2 = sum S_ij^2/2)
    Sg = sp.Matrix(2, 2, sp.symbols("S11 S12 S21 S22", real=True))
    nS2 = (Sg * Sg.T).trace() / 2
    vphi = 2 * d * sp.sqrt(rho) * Mf_ / Pf_ * nS2 * sp.sqrt(p) - Mf_ * Pf_ / (6 * d * sp.sqrt(rho)) * p ** sp.Rational(3, 2)
    grad = sp.Matrix(2, 2, lambda i, j: sp.diff(vphi, Sg[i, j]))
    tau414 = cidr.icidr_deviatoric_stress(Sg, sp.sqrt(p))
    ok10 = all(exact_zero(x) for x in (grad - tau414))
    Ssc = sp.sqrt(nS2)
    second10 = Mf_ / Pf_ * (2 * d * Ssc / sp.sqrt(p / rho)) * Sg / Ssc * p
    ok10b = all(exact_zero(x) for x in (grad - second10))
    out.append(Check("(B9a)/(B10)", "d varphi/d S_ij = 2 d sqrt(rho) M/Psi S_ij sqrt(p) = tau_ij of (4.14)",
                     EXACT if ok10 and ok10b else FAILS, "both printed forms of (B10) equal (4.14)", section=sec))
    vphiS = (2 * d * sp.sqrt(rho) * Mf_ / Pf_ * Sn**2 * sp.sqrt(p)       # (B8) with ||S|| = S_n
             - Mf_ * Pf_ / (6 * d * sp.sqrt(rho)) * p ** sp.Rational(3, 2))
    dvp = sp.diff(vphiS, p)
    pr11a = d * sp.sqrt(rho) * Mf_ / Pf_ * Sn**2 / sp.sqrt(p) - Mf_ * Pf_ / (4 * d * sp.sqrt(rho)) * sp.sqrt(p)
    pr11b = Mf_ * Sn / 2 * (1 / Pf_ * 2 * d * Sn / sp.sqrt(p / rho) - Pf_ * sp.sqrt(p / rho) / (2 * d * Sn))
    flow = (2 * fI * Sn).subs(I, Idef)
    ok11 = exact_zero(dvp - pr11a) and exact_zero(dvp - pr11b) and exact_zero(dvp - flow)
    out.append(Check("(B9b)/(B11)", "d varphi/dp = both printed forms = 2 f ||S|| = div u by (4.2), (4.8)",
                     EXACT if ok11 else FAILS, "", section=sec))

    # (B7)/(B12): Legendre pair.  psi(S, delta) = varphi(S, P) - P delta with P from (4.12)
    P412 = cidr.icidr_pressure(delta, Sn)
    psi_Sd = vphiS.subs(p, P412) - P412 * delta
    # stationarity of psi(S, delta) + p delta in delta is P(S, delta*) = p with delta* = d varphi/dp
    ok7 = numeric_zero(P412.subs(delta, dvp) - p, scale=p)
    dPd = sp.simplify(sp.diff(P412, delta))
    R = sp.sqrt(delta**2 + Mf_**2 * Sn**2)
    okconv = exact_zero(dPd - 2 * sp.sqrt(rho) * 2 * d / (Mf_ * Pf_) * cidr.icidr_sqrt_pressure(delta, Sn)
                        * (delta / R - 1))
    ok12 = numeric_zero(psi_Sd.subs(delta, dvp) + p * dvp - vphiS, scale=abs(vphiS) + p**2)
    out.append(Check("(B7)/(B12)", "varphi(S,p) = inf_delta psi(S,delta) + p delta, attained at delta = d varphi/dp; "
                     "d^2 psi/d delta^2 = -dP/d delta > 0 (a minimum)",
                     NUMERIC if ok7 and ok12 and okconv else FAILS,
                     "P(S, d varphi/dp) = p and the values agree (30 digits); dP/d delta = 2 sqrt(P) (2d sqrt(rho)/(M Psi)) "
                     "(delta/R - 1) < 0 exactly", section=sec))
    psi13 = vphiS - p * dvp
    printed13 = d * Mf_ * sp.sqrt(rho) / Pf_ * Sn**2 * sp.sqrt(p) + Mf_ * Pf_ / (12 * d * sp.sqrt(rho)) * p ** sp.Rational(3, 2)
    out.append(compare("(B13)", "psi in mixed variables (S, p): varphi - p d varphi/dp", psi13, printed13, section=sec))
    ok14 = exact_zero(psi13 - D6 / 3)
    out.append(Check("(B14)", "psi = D/3", EXACT if ok14 else FAILS, "(B13) - (B6)/3 = 0", section=sec))

    # (B15): D homogeneous of degree 3 in D (shear cell and general 2-D), integral gives D/3
    kin = rheologies.shear_cell_kinematics()
    P_sc = cidr.icidr_pressure(kin["div"], kin["normS"])
    Dsc = D6.subs(Sn, kin["normS"]).subs(p, P_sc)
    lamb = sp.Symbol("l", positive=True)
    hom = exact_zero(Dsc.subs({uz: lamb * uz, wz: lamb * wz}, simultaneous=True) - lamb**3 * Dsc)
    integ = sp.integrate(lamb**3 / lamb, (lamb, 0, 1))
    _, div, Sgen = general_strain()
    nS2g = sp.expand((Sgen * Sgen).trace() / 2)
    Pg = cidr.icidr_pressure(div, sp.sqrt(nS2g))
    Dg = D6.subs(Sn, sp.sqrt(nS2g)).subs(p, Pg)
    homg = exact_zero(Dg.subs({A_: lamb * A_, B_: lamb * B_, C_: lamb * C_}, simultaneous=True) - lamb**3 * Dg)
    out.append(Check("(B15)", "D(lambda D) = lambda^3 D(D), so int_0^1 D(lambda D) d lambda/lambda = D/3 = psi",
                     EXACT if hom and homg and integ == sp.Rational(1, 3) else FAILS,
                     "degree-3 homogeneity checked in the shear cell and for general 2-D D", section=sec))

    # sigma = d psi/d D in the shear cell: d psi/d u_z = tau_xz, d psi/d w_z = tau_zz - p
    psi_sc = (D6 / 3).subs(Sn, kin["normS"]).subs(p, P_sc)
    pp, txz, tzz = rheologies.icidr_stress()
    okg = numeric_zero(sp.diff(psi_sc, uz) - txz, scale=abs(txz)) and numeric_zero(
        sp.diff(psi_sc, wz) - (tzz - pp), scale=abs(pp))
    out.append(Check("(B15) sigma = dpsi/dD", "shear cell: d psi/d u_z = tau_xz, d psi/d w_z = tau_zz - p "
                     "(so Gamma = Hess(psi)/(rho phi) is symmetric)", NUMERIC if okg else FAILS,
                     "30 digits at random rational points (generic M, Psi)", section=sec))
    conv = convexity_sample()
    out.append(Check("(B15) convexity", "psi(D) is convex (assumed in the paper, not proved there)",
                     NUMERIC if conv["ok"] else FAILS,
                     f"Hessian of psi(D) in (D_xx, D_xz, D_zz) at {conv['n']} random states (Table 1, phi in "
                     f"(0.6, phi_c)): min eigenvalue/max |eigenvalue| = {conv['min_ratio']:.2e} "
                     f"(>= -1e-9 required; double precision, not 30 digits); shear-cell restriction proved "
                     f"exactly via Gamma", section=sec))
    return out


@lru_cache(maxsize=None)
def _psi_hessian_lambda():
    psi, _, _, _ = psi_of_D()
    vars3 = (A_, B_, C_)
    H = sp.hessian(psi, vars3)
    return sp.lambdify((A_, B_, C_, M, Psi), H, modules="numpy")


def convexity_sample(n=400, seed=5, material=None):
    """Eigenvalues of the Hessian of psi(D) at `n` random strain rates and phi in (0.6, phi_c)."""
    from .material import default_material  # noqa: PLC0415

    material = default_material(material)
    phi_max = material.phi_range[1]
    rng = np.random.default_rng(seed)
    H = _psi_hessian_lambda()
    worst = np.inf
    for _ in range(n):
        ph = rng.uniform(0.6, phi_max - 1e-3)
        Mv, Pv = float(material.M(ph)), float(material.Psi(ph))
        A, B, C = rng.normal(size=3)
        h = np.asarray(H(A, B, C, Mv, Pv), dtype=float)
        ev = np.linalg.eigvalsh((h + h.T) / 2)
        worst = min(worst, ev.min() / np.abs(ev).max())
    return {"ok": bool(worst >= -1e-9), "min_ratio": float(worst), "n": n}
