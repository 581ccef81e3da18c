"""Symbolic constitutive laws of the 1-D shear cell, from the simulator's one definition.

Each rheology is defined once, on invariants, in :mod:`icidr_pde.rheology`
(:meth:`~icidr_pde.rheology.Rheology.law`: (phi, div u, ||S||) -> (p, c), tau = c S). This
module evaluates that definition in the shear cell for the toolkit:

* kinematics (3.4)-(3.5) from the velocity gradient of u = (u(z), w(z)), with the
  simulator's (2.4)-(2.5) (:func:`icidr_pde.rheology.kinematics.strain_rate`);
* the laws with *generic* M(phi), Psi(phi) (so that identities hold for any material
  functions) and dimensional d, rho_*: every law is non-dimensional with (3.12) and carries
  the Bagnold scaling, so the dimensional stresses are rho_* d^2 times the simulator's;
* :func:`concrete_functions`: M and Psi of a :class:`~icidr_pde.rheology.Material`
  (default (2.10), (2.13), Table 1), with its parameters as symbols.

The checks of :mod:`stability.mui`, :mod:`stability.icidr` and :func:`checks` compare these
expressions with the printed (2.14), (3.6), (3.8), (4.12), (5.1)-(5.6), derived from the
general laws; :func:`numeric_stress` (``sympy.lambdify``) cross-checks the simulator's
generated kernels.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import sympy as sp

from icidr_pde.rheology import get_rheology
from icidr_pde.rheology.kinematics import strain_rate

from . import cidr
from .material import check_phi, check_rate, check_rheology_name, default_material
from .symbols import I, Mf, Psif, a, d, phi, phi_c, rho, uz, wz


def mu_of_I(Ival, material=None):
    """Friction law of `material` (default (2.10)) with symbolic parameters."""
    return default_material(material).symbolic_mu(Ival, symbolic=True)


def Phi_of_I(Ival, material=None):
    """Steady packing law of `material` (default (2.11)) with symbolic parameters."""
    return default_material(material).symbolic_Phi(Ival, symbolic=True)


@lru_cache(maxsize=None)
def Psi_of_phi_derived():
    """Psi(phi), the inverse of (2.11), obtained by solving Phi(I) = phi for I ((2.12)-(2.13))."""
    (sol,) = sp.solve(sp.Eq(Phi_of_I(I), phi), I)
    return sol


def concrete_functions(material=None):
    """Substitution {M(phi): mu(Psi(phi)), Psi(phi): Psi(phi)} of `material`, symbolic parameters."""
    material = default_material(material)
    return {Mf(phi): material.symbolic_M(phi, symbolic=True), Psif(phi): material.symbolic_Psi(phi, symbolic=True)}


@lru_cache(maxsize=None)
def shear_cell_kinematics():
    """Velocity gradient, D (2.4), div u, S (2.5)/(3.4) and ||S|| (3.5) for u = (u(z), w(z)).

    Coordinates (x, z); grad_u[i, j] = d_j u_i, so only the z column is non-zero.
    """
    grad_u = sp.Matrix([[0, uz], [0, wz]])
    div, S, normS = strain_rate(grad_u)
    return {"grad_u": grad_u, "D": (grad_u + grad_u.T) / 2, "div": div, "S": S, "normS": normS}


def _material(M=None, Psi=None):
    return (Mf(phi) if M is None else M), (Psif(phi) if Psi is None else Psi)


def stress(name: str, M=None, Psi=None):
    """(p, tau_xz, tau_zz) of rheology `name` in the shear cell, dimensional (d, rho_*).

    The simulator's definition with M, Psi defaulting to the generic functions M(phi),
    Psi(phi); pass expressions (or plain symbols) to specialise.
    """
    check_rheology_name(name)
    rheology = get_rheology(name)
    M, Psi = _material(M, Psi)
    k = shear_cell_kinematics()
    p, c = rheology.law(phi, k["div"], k["normS"], M, Psi, rheology.material.values(symbolic=True))
    scale = rho * d**2
    tau = scale * c * k["S"]
    return sp.simplify(scale * p), sp.simplify(tau[0, 1]), sp.simplify(tau[1, 1])


def mui_stress(M=None, Psi=None):
    """(p, tau_xz, tau_zz) of mu(I),Phi(I): (2.14) and the alignment (2.6) with (2.7)."""
    return stress("mui", M, Psi)


def icidr_stress(M=None, Psi=None):
    """(p, tau_xz, tau_zz) of iCIDR: (4.12) and (4.14) (verified against :mod:`stability.cidr`)."""
    return stress("icidr", M, Psi)


@lru_cache(maxsize=None)
def concrete_stress(name: str, material=None):
    """Stress with M, Psi of `material` (default (2.10), (2.13)), symbolic parameters, d = rho_* = 1."""
    subs = concrete_functions(material)
    return tuple(e.subs(subs).subs({d: 1, rho: 1}) for e in stress(name))


def parameter_symbols(material=None) -> tuple:
    """Symbols of `material`'s parameters, in the order of ``material.params``."""
    material = default_material(material)
    values = material.values(symbolic=True)
    return tuple(values[k] for k in material.parameter_names())


@lru_cache(maxsize=None)
def _compiled_stress(name: str, laws=None):
    material = default_material() if laws is None else laws
    args = (phi, uz, wz, *parameter_symbols(material))
    return sp.lambdify(args, concrete_stress(name, material), modules="numpy")


def _law_representative(material):
    """A material with the same laws (the compiled form depends on the laws, not the values)."""
    material = default_material(material)
    return type(material)(friction=type(material.friction)(), dilatancy=type(material.dilatancy)())


def compiled_stress(name: str, material=None):
    """lambdify'd (p, tau_xz, tau_zz)(phi, u_z, w_z, *material.params) (works for complex input)."""
    return _compiled_stress(name, _law_representative(material))


def numeric_stress(name: str, phi_v, uz_v, wz_v, material=None):
    """Evaluate (p, tau_xz, tau_zz) of rheology `name` on numpy arrays (d = rho_* = 1).

    Raises ValueError for phi outside the inertial range or non-finite strain rates.
    """
    check_rheology_name(name)
    material = default_material(material)
    phi_v = check_phi(phi_v, material)
    uz_v, wz_v = check_rate(uz_v, "uz"), check_rate(wz_v, "wz")
    res = compiled_stress(name, material)(phi_v, uz_v, wz_v, *material.params)
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
    return out + simulator_checks()


def simulator_checks():
    """The simulator's laws on general invariants (div u, ||S||) against their derivations.

    mu(I),Phi(I): p from (2.9) at I = Psi(phi), i.e. (2.14), and ||tau|| = c ||S|| = mu p (2.7).
    iCIDR: p equals (4.11) at the root (4.10) of the flow rule (derived from (4.7)-(4.8) in
    :mod:`stability.cidr`), ||tau|| = c ||S|| equals the yield function (4.7) with I from
    (2.9), and the cancellation-free form the kernels evaluate is the same function.
    """
    from .checks import EXACT, FAILS, Check, compare, exact_zero  # noqa: PLC0415
    from .symbols import Sn, delta  # noqa: PLC0415
    from .symbols import p as p_sym  # noqa: PLC0415

    M, Psi = Mf(phi), Psif(phi)
    scale = rho * d**2
    (p_of_I,) = sp.solve(sp.Eq(I, cidr.inertial_number_definition()), p_sym)
    out = []
    p_mui, c_mui = get_rheology("mui").law(phi, delta, Sn, M, Psi, {})
    ok = exact_zero(scale * p_mui - p_of_I.subs(I, Psi)) and exact_zero(scale * c_mui * Sn - M * scale * p_mui)
    out.append(Check("(2.14) simulator", "the simulator's mu(I) law: p = rho (2 d ||S||/Psi)^2 from (2.9) at "
                     "I = Psi(phi), ||tau|| = c ||S|| = mu(Psi) p (2.6)-(2.7), for every div u",
                     EXACT if ok else FAILS, "icidr_pde.rheology.MuIPhiI.law on (div u, ||S||), times rho_* d^2",
                     section="simulator"))
    icidr = get_rheology("icidr")
    p_i, c_i = icidr.law(phi, delta, Sn, M, Psi, {})
    p_route = p_of_I.subs(I, cidr.icidr_inertial_number())
    c = compare("(4.12) simulator", "the simulator's iCIDR pressure equals (4.11) at the root (4.10) of the "
                "flow rule (4.2) with (4.8)", scale * p_i, p_route, section="simulator")
    out.append(c)
    Y = cidr.yield_icidr().subs(I, cidr.inertial_number_definition()).subs(p_sym, scale * p_i)
    c = compare("(4.14) simulator", "the simulator's iCIDR ||tau|| = c ||S|| equals the yield function (4.7) "
                "with I from (2.9)", scale * c_i * Sn, Y, section="simulator", try_exact=False)
    out.append(c)
    p_s, c_s = icidr.law(phi, delta, Sn, M, Psi, {}, stable=True)
    signs = (sp.Symbol("dpos", positive=True), sp.Symbol("dneg", negative=True), 0)
    ok = all(exact_zero(stable.subs(delta, v) - plain.subs(delta, v))
             for stable, plain in ((p_s, p_i), (c_s, c_i)) for v in signs)
    out.append(Check("(4.12) stable form", "the kernels' cancellation-free form M^2||S||^2/(R + div u) for div u > 0 "
                     "is the same function as R - div u", EXACT if ok else FAILS,
                     "(R - div)(R + div) = M^2 ||S||^2, R = sqrt(div^2 + M^2 ||S||^2)", section="simulator"))
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
