"""Symbolic constitutive laws of the 1-D shear cell: mu(I),Phi(I) and iCIDR.

One definition of each rheology, as sympy expressions p(phi, u_z, w_z),
tau_xz(...), tau_zz(...), built from the tensor formulas rather than typed in:

* kinematics (3.4)-(3.5): velocity gradient of u = (u(z), w(z)), D (2.4), S (2.5),
  ||T|| = sqrt(tr(T^2)/2);
* mu(I),Phi(I): (2.14) for p and the alignment (2.6) with (2.7) for tau, i.e. (3.6), (3.8);
* iCIDR: (4.12) for p and (4.14) for tau, both derived and verified in
  :mod:`stability.cidr` from the yield function (4.7) and dilatancy (4.8).

:func:`numeric_stress` compiles them with ``sympy.lambdify`` (d = rho_* = 1); the
simulator's hand-written kernels are cross-checked against these in the tests.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

from . import cidr
from .material import check_phi, check_rate, check_rheology_name, material_params
from .symbols import MATERIAL_SYMBOLS, I, I0, Mf, Psif, a, d, mu_d, mu_s, phi, phi_c, rho, uz, wz


def mu_of_I(Ival):
    """Friction law (2.10): mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1)."""
    return mu_s + (mu_d - mu_s) / (I0 / Ival + 1)


def Phi_of_I(Ival):
    """Steady packing law (2.11): Phi(I) = phi_c - a I."""
    return phi_c - a * Ival


@lru_cache(maxsize=None)
def Psi_of_phi_derived():
    """Psi(phi), the inverse of (2.11), obtained by solving Phi(I) = phi for I ((2.12)-(2.13))."""
    (sol,) = sp.solve(sp.Eq(Phi_of_I(I), phi), I)
    return sol


def concrete_functions():
    """Substitution {M(phi): mu(Psi(phi)), Psi(phi): Psi(phi)} with (2.10), (2.13) and symbolic parameters."""
    psi = Psi_of_phi_derived()
    return {Mf(phi): mu_of_I(psi), Psif(phi): psi}


@lru_cache(maxsize=None)
def shear_cell_kinematics():
    """Velocity gradient, D (2.4), div u, S (2.5)/(3.4) and ||S|| (3.5) for u = (u(z), w(z)).

    Coordinates (x, z); grad_u[i, j] = d_j u_i, so only the z column is non-zero.
    """
    grad_u = sp.Matrix([[0, uz], [0, wz]])
    D = (grad_u + grad_u.T) / 2
    div = D.trace()
    S = D - div / 2 * sp.eye(2)
    normS = sp.sqrt(sp.simplify((S * S).trace() / 2))
    return {"grad_u": grad_u, "D": D, "div": div, "S": S, "normS": normS}


def _material(M=None, Psi=None):
    return (Mf(phi) if M is None else M), (Psif(phi) if Psi is None else Psi)


def mui_stress(M=None, Psi=None):
    """(p, tau_xz, tau_zz) of mu(I),Phi(I) in the shear cell, from (2.14), (2.6), (2.7).

    M, Psi default to the generic functions M(phi), Psi(phi); pass expressions to specialise.
    """
    M, Psi = _material(M, Psi)
    k = shear_cell_kinematics()
    S, normS = k["S"], k["normS"]
    p = rho * (2 * d * normS / Psi) ** 2                       # (2.14)
    tau = M * p * S / normS                                     # (2.6) with ||tau|| = mu p (2.7)
    return sp.simplify(p), sp.simplify(tau[0, 1]), sp.simplify(tau[1, 1])


def icidr_stress(M=None, Psi=None):
    """(p, tau_xz, tau_zz) of iCIDR in the shear cell, from (4.12) and (4.14).

    (4.12) and (4.14) are the general-deformation formulas verified in
    :mod:`stability.cidr`; here div u and ||S|| come from the shear-cell kinematics.
    sqrt(p) is taken as the non-negative root (4.12) is the square of (verified in cidr).
    """
    M, Psi = _material(M, Psi)
    k = shear_cell_kinematics()
    sqrt_p = cidr.icidr_sqrt_pressure(k["div"], k["normS"], M, Psi)
    p = sqrt_p ** 2
    tau = cidr.icidr_deviatoric_stress(k["S"], sqrt_p, M, Psi)
    return p, sp.simplify(tau[0, 1]), sp.simplify(tau[1, 1])


def stress(name: str, M=None, Psi=None):
    """Dispatch to :func:`mui_stress` ('mui') or :func:`icidr_stress` ('icidr')."""
    check_rheology_name(name)
    return mui_stress(M, Psi) if name == "mui" else icidr_stress(M, Psi)


def momentum_fluxes(name: str, M=None, Psi=None):
    """Fluxes of (3.2)-(3.3): F = (tau_xz, tau_zz - p)."""
    p, txz, tzz = stress(name, M, Psi)
    return txz, tzz - p


@lru_cache(maxsize=None)
def concrete_stress(name: str):
    """Stress with M = mu(Psi(phi)), Psi from (2.10), (2.13), symbolic parameters, d = rho_* = 1."""
    subs = concrete_functions()
    out = []
    for e in stress(name):
        out.append(e.subs(subs).subs({d: 1, rho: 1}))
    return tuple(out)


@lru_cache(maxsize=None)
def _compiled_stress(name: str):
    args = (phi, uz, wz, *MATERIAL_SYMBOLS.values())
    return sp.lambdify(args, concrete_stress(name), modules="numpy")


def numeric_stress(name: str, phi_v, uz_v, wz_v, material=None):
    """Evaluate (p, tau_xz, tau_zz) of rheology `name` on numpy arrays (d = rho_* = 1).

    Raises ValueError for phi outside (0, phi_c) or non-finite strain rates.
    """
    check_rheology_name(name)
    prm = material_params(material)
    phi_v = check_phi(phi_v, material)
    uz_v, wz_v = check_rate(uz_v, "uz"), check_rate(wz_v, "wz")
    f = _compiled_stress(name)
    res = f(phi_v, uz_v, wz_v, *(prm[k] for k in MATERIAL_SYMBOLS))
    shape = np.broadcast(phi_v, uz_v, wz_v).shape
    return tuple(np.broadcast_to(np.asarray(r, dtype=float), shape) for r in res)


def checks():
    """Verify (2.13), (3.4) and the non-dimensional flux forms (3.14)-(3.15), (5.4)-(5.5)."""
    from .checks import EXACT, FAILS, Check, compare, exact_zero  # noqa: PLC0415
    from .symbols import Mf as _M, Psif as _P  # noqa: PLC0415

    out = [momentum_index_check()]
    out += [compare("(2.13)", "Psi(phi) = (phi_c - phi)/a inverts (2.11)", Psi_of_phi_derived(),
                   (phi_c - phi) / a, section="2")]
    k = shear_cell_kinematics()
    S34 = sp.Matrix([[-wz, uz], [uz, wz]]) / 2
    out.append(Check("(3.4)", "S = (1/2)[[-w_z, u_z], [u_z, w_z]] and div u = w_z",
                     EXACT if (k["S"] - S34).is_zero_matrix and k["div"] == wz else FAILS, "", section="3"))
    s = sp.sqrt(uz**2 + wz**2)
    p, txz, tzz = [e.subs({d: 1, rho: 1}) for e in mui_stress()]
    M, Psi = _M(phi), _P(phi)
    ok = exact_zero(txz - M / Psi**2 * s * uz) and exact_zero(tzz - p - (-(s**2) / Psi**2 + M / Psi**2 * s * wz))
    out.append(Check("(3.14)-(3.15)", "non-dimensional mu(I) fluxes: tau_xz = M/Psi^2 s u_z, "
                     "tau_zz - p = -s^2/Psi^2 + M/Psi^2 s w_z", EXACT if ok else FAILS, "d = rho_* = 1 (3.12)",
                     section="3"))
    p, txz, tzz = [e.subs({d: 1, rho: 1}) for e in icidr_stress()]
    sqrt_p = cidr.icidr_sqrt_pressure(wz, s / 2, M, Psi).subs({d: 1, rho: 1})
    ok = exact_zero(txz - M / Psi * sqrt_p * uz) and exact_zero(tzz - p - (-p + M / Psi * sqrt_p * wz))
    out.append(Check("(5.4)-(5.5)", "non-dimensional iCIDR fluxes (M/Psi) sqrt(p~) u_z and -p~ + (M/Psi) sqrt(p~) w_z",
                     EXACT if ok else FAILS, "with the corrected p~ of (5.6)", section="5 iCIDR"))
    return out


def momentum_index_check():
    """(2.2) as transcribed, rho phi (d_t + u_i d_i) u_i = d_i sigma_ii, has no free index.

    The correct law is rho phi (d_t + u_j d_j) u_i = d_j sigma_ij.  In the shear cell
    (fields of z only) the correct form gives (3.2)-(3.3), d_z tau_xz and
    d_z(tau_zz - p); the printed one would give d_x sigma_xx = 0 for i = 1.
    """
    from .checks import EXACT, FAILS, Check  # noqa: PLC0415

    z, x = sp.symbols("z x", real=True)
    pf, txz, tzz = (sp.Function(n)(z) for n in ("p", "tau_xz", "tau_zz"))
    sigma = sp.Matrix([[-pf - tzz, txz], [txz, -pf + tzz]])   # (2.3), tau trace-free
    X = (x, z)
    correct = [sum(sp.diff(sigma[i, j], X[j]) for j in range(2)) for i in range(2)]
    printed = [sp.diff(sigma[i, i], X[i]) for i in range(2)]
    ok_correct = sp.simplify(correct[0] - sp.diff(txz, z)) == 0 and sp.simplify(
        correct[1] - sp.diff(tzz - pf, z)) == 0
    ok_printed = sp.simplify(printed[0] - sp.diff(txz, z)) == 0
    return Check("(2.2)", "momentum: rho_* phi (d_t + u_i d_i) u_i = d_i sigma_ii, i = 1, 2 (as transcribed)",
                 FAILS if (ok_correct and not ok_printed) else EXACT,
                 "printed index form has no free index and would give d_x sigma_xx = 0 for i = 1; the correct form "
                 "reproduces (3.2)-(3.3)" if ok_correct else "correct form does not reproduce (3.2)-(3.3)!",
                 corrected="rho_* phi (d_t + u_j d_j) u_i = d_j sigma_ij, i = 1, 2 (sum over j)", section="2")
