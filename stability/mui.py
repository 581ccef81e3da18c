"""Appendix A for the mu(I),Phi(I)-rheology: (A10)-(A19) and the indicator chi.

Coefficients come from :func:`stability.linearize.principal_coefficients` applied to
the symbolic stress of :func:`stability.rheologies.mui_stress` (generic M(phi),
Psi(phi), dimensional d and rho_*), and are compared with the printed (A10)-(A14).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

from . import linearize, rheologies
from .checks import EXACT, FAILS, Check, compare, exact_zero
from icidr_pde.rheology import chi as core_chi

from .material import check_phi, check_rate, default_material
from .symbols import Mf, Psif, d, phi, rho, uz, wz

SECTION = "A mu(I)"


@lru_cache(maxsize=None)
def coefficients():
    """(A10) coefficients derived by differentiating the fluxes of (3.6), (3.8)."""
    return {k: sp.simplify(v) for k, v in linearize.principal_coefficients(*rheologies.mui_stress()).items()}


def printed_A10():
    """The transcription's (A10), with ||S|| from (A11b); used only as the claim under test."""
    M, Psi = Mf(phi), Psif(phi)
    S = sp.sqrt(uz**2 + wz**2) / 2
    dMP = sp.diff(M / Psi**2, phi)
    dP = sp.diff(1 / Psi**2, phi)
    K = d**2 * M / (2 * phi * Psi**2)
    return {
        "a1": 2 * d**2 / phi * uz * S * dMP,
        "a2": 2 * d**2 * S / phi * (wz * dMP - 2 * S * dP),
        "b11": K * (2 * uz**2 + wz**2) / S,
        "b12": K * uz * wz / S,
        "b21": K * uz * wz / S - 2 * d**2 / (phi * Psi**2) * uz,
        "b22": K * (uz**2 + 2 * wz**2) / S - 2 * d**2 / (phi * Psi**2) * wz,
    }


def checks() -> list[Check]:
    """Verify (3.5)-(3.8), (A10)-(A18) for mu(I),Phi(I)."""
    sec = SECTION
    out = []
    M, Psi = Mf(phi), Psif(phi)
    s = sp.sqrt(uz**2 + wz**2)
    kin = rheologies.shear_cell_kinematics()
    out.append(compare("(3.5)", "||S|| = sqrt(u_z^2 + w_z^2)/2 from S (3.4)", kin["normS"], s / 2, section="3"))
    p, txz, tzz = rheologies.mui_stress()
    out.append(compare("(3.6)", "p = rho d^2 (u_z^2 + w_z^2)/Psi^2 from (2.14)", p,
                       rho * d**2 / Psi**2 * (uz**2 + wz**2), section="3"))
    okt = exact_zero(txz - M * p * uz / s) and exact_zero(tzz - M * p * wz / s)
    out.append(Check("(3.8)", "tau = mu(Psi) p (u_z, w_z)/sqrt(u_z^2 + w_z^2) from (2.6)-(2.7)",
                     EXACT if okt else FAILS, "", section="3"))

    c = coefficients()
    pr = printed_A10()
    bad = []
    for k in ("a1", "a2", "b11", "b12", "b21", "b22"):
        if not exact_zero(c[k] - pr[k]):
            bad.append(k)
    out.append(Check("(A10)", "a_i, b_ij of (A2) for mu(I),Phi(I) (with the d^2 factor; rho_* cancels)",
                     EXACT if not bad else FAILS,
                     "all six coefficients equal dF_i/d(.)/(rho_* phi)" if not bad else f"mismatch in {bad}",
                     corrected=None if not bad else "; ".join(f"{k} = {sp.sstr(c[k])}" for k in bad), section=sec))
    G = linearize.gamma_matrix(c)
    tr, det = sp.simplify(G.trace()), sp.simplify(G.det())
    out.append(compare("(A12)", "tr Gamma = d^2/(phi Psi^2) [3 M sqrt(u_z^2+w_z^2) - 2 w_z]", tr,
                       d**2 / (phi * Psi**2) * (3 * M * s - 2 * wz), section=sec))
    out.append(compare("(A13)", "det Gamma = 2 d^4 M/(phi^2 Psi^4) sqrt(.)[M sqrt(.) - w_z]", det,
                       2 * d**4 * M / (phi**2 * Psi**4) * s * (M * s - wz), section=sec))
    disc = sp.simplify(tr**2 - 4 * det)
    printed14 = (2 * d**2 / (phi * Psi**2)) ** 2 * (M * s / 2 - wz) ** 2
    c14 = compare("(A14)", "(tr Gamma)^2 - 4 det Gamma = (2d^2/(phi Psi^2))^2 (M||S|| - w_z)^2 >= 0", disc,
                  printed14, section=sec)
    alt = (2 * d**2 / (phi * Psi**2)) ** 2 * (M * s - wz) ** 2
    alt_ok = exact_zero(disc - alt)
    c14.detail += ("; with ||S|| = sqrt(u_z^2+w_z^2)/2 as printed. The alternative reading "
                   f"M sqrt(u_z^2+w_z^2) in place of M||S|| is {'also valid' if alt_ok else 'WRONG'}")
    out.append(c14)

    r1 = -d**2 * M * s / (phi * Psi**2)
    r2 = 2 * d**2 * (wz - M * s) / (phi * Psi**2)
    okr = exact_zero(r1 + r2 + tr) and exact_zero(r1 * r2 - det)
    out.append(Check("(A9) mu(I)", "for mu(I) the roots (A9) are Lambda = -d^2 M s/(phi Psi^2) and "
                     "2 d^2 (w_z - M s)/(phi Psi^2), s = sqrt(u_z^2+w_z^2) (real, by (A14))",
                     EXACT if okr else FAILS, "Vieta: r1 + r2 = -tr Gamma, r1 r2 = det Gamma", section=sec))

    # (A15): Lambda_+ > 0 iff tr < 0 or det < 0 (real roots); tr < 0 => det < 0 for mu(I)
    X, Y = 3 * M * s - 2 * wz, M * s - wz
    ok15 = exact_zero(tr - d**2 / (phi * Psi**2) * X) and exact_zero(2 * Y - X + M * s)
    out.append(Check("(A15)", "tr Gamma < 0 implies det Gamma < 0: 2(M s - w_z) = (3 M s - 2 w_z) - M s",
                     EXACT if ok15 else FAILS, "s = sqrt(u_z^2 + w_z^2) > 0, M > 0", section=sec))
    # (A16): det < 0 <=> w_z/s > M since det = (2 d^4 M s/(phi^2 Psi^4)) (M s - w_z), prefactor > 0
    pref = 2 * d**4 * M * s / (phi**2 * Psi**4)
    ok16 = exact_zero(det - pref * s * (M - wz / s))
    out.append(Check("(A16)", "det Gamma < 0 iff w_z/sqrt(u_z^2+w_z^2) > M: sufficient for ill-posedness",
                     EXACT if ok16 else FAILS, "det Gamma = 2 d^4 M s^2/(phi^2 Psi^4) (M - w_z/s)", section=sec))
    ok17 = exact_zero(X - (M * s + 2 * Y))
    out.append(Check("(A17)", "w_z/s < M implies tr Gamma > 0 and det Gamma > 0 (Lambda_pm < 0): well-posed",
                     EXACT if ok17 else FAILS, "3 M s - 2 w_z = M s + 2 (M s - w_z) > 0", section=sec))

    # (A18): chi > 0 <=> (A16) for M < 1, u_z != 0
    m = sp.Symbol("m", positive=True)          # M, assumed 0 < m < 1
    U = sp.Symbol("U", positive=True)          # |u_z| > 0
    t = sp.Symbol("t", real=True)              # w_z/|u_z|
    k = m / sp.sqrt(1 - m**2)
    lhs = (t * U) ** 2 - m**2 * (U**2 + (t * U) ** 2)   # w_z^2 - M^2 (u_z^2 + w_z^2)
    ok18 = exact_zero(lhs - (1 - m**2) * U**2 * (t - k) * (t + k))
    out.append(Check("(A18)", "chi = w_z/|u_z| - M/sqrt(1-M^2) > 0 iff (A16), provided 0 < M < 1 and u_z != 0",
                     EXACT if ok18 else FAILS,
                     "w_z^2 - M^2(u_z^2+w_z^2) = (1-M^2) u_z^2 (t - k)(t + k), t = w_z/|u_z|, k = M/sqrt(1-M^2); "
                     "for w_z > 0 (t + k > 0) the signs agree, for w_z <= 0 both are false. Needs M < 1 (for M >= 1 "
                     "chi is not real and (A16) never holds since w_z/s <= 1) and u_z != 0 (chi = +-inf there; "
                     "(A16) holds iff w_z > 0). Table 1 gives M in [mu_s, mu_d) = [0.248, 0.588), so M < 1.",
                     section=sec))
    return out


def chi(phi_v, uz_v, wz_v, material=None):
    """chi of (A18) on arrays (simulator fields): > 0 ill-posed (A16), < 0 well-posed (A17).

    The simulator's :func:`icidr_pde.rheology.chi`: u_z = 0 gives +inf (w_z > 0), -inf
    (w_z < 0) or nan (w_z = 0, where Gamma = 0 and (A16)/(A17) are undefined). Raises
    ValueError for phi outside the inertial range or non-finite rates.
    """
    check_phi(phi_v, material)
    uz_v, wz_v = check_rate(uz_v, "uz"), check_rate(wz_v, "wz")
    return core_chi(phi_v, uz_v, wz_v, default_material(material))


def M_numeric(phi_v, material=None):
    """M(phi) = mu(Psi(phi)) of (A11a) for `material` (default (2.10), (2.13), Table 1)."""
    return np.asarray(default_material(material).M(np.asarray(phi_v, float)), dtype=float)
