"""Numerical evaluation of the symbols: coefficients (A2), A(xi), Gamma, Lambda, -C/B.

Everything is compiled once per pair of material laws (``sympy.lambdify``) from the
symbolic derivation of :mod:`stability.linearize` applied to :mod:`stability.rheologies`
with the material's functions M(phi), Psi(phi) (default (2.10), (2.13)) and d = rho_* = 1.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
import sympy as sp

from . import linearize, rheologies
from .material import check_phi, check_rate, check_rheology_name, check_xi, default_material
from .mui import M_numeric, chi
from . import symbols as S

NAMES = ("a1", "a2", "b11", "b12", "b21", "b22")


@lru_cache(maxsize=None)
def _coefficient_lambda(name: str, laws):
    p, txz, tzz = rheologies.stress(name)
    c = linearize.principal_coefficients(p, txz, tzz)
    subs = rheologies.concrete_functions(laws)
    exprs = [c[k].subs(subs).doit().subs({S.d: 1, S.rho: 1}) for k in NAMES]
    return sp.lambdify((S.phi, S.uz, S.wz, *rheologies.parameter_symbols(laws)), exprs, modules="numpy")


def _validate_state(name, phi_v, uz_v, wz_v, material):
    check_rheology_name(name)
    check_phi(phi_v, material)
    check_rate(uz_v, "uz")
    check_rate(wz_v, "wz")
    if np.any((np.asarray(uz_v) == 0) & (np.asarray(wz_v) == 0)):
        raise ValueError("`uz`, `wz` must not both be 0: at zero strain rate Gamma = 0 and the system is "
                         "degenerate (see stability.icidr); give (uz, wz) != (0, 0)")


def coefficients(name, phi_v, uz_v, wz_v, material=None) -> dict:
    """a1, a2, b11, b12, b21, b22 of (A2) for rheology `name` at a base state (d = rho_* = 1)."""
    _validate_state(name, phi_v, uz_v, wz_v, material)
    material = default_material(material)
    f = _coefficient_lambda(name, rheologies._law_representative(material))
    vals = f(float(phi_v), float(uz_v), float(wz_v), *material.params)
    return {k: float(v) for k, v in zip(NAMES, vals)}


def A_matrix(c: dict, phi_v: float, xi_v: float, w0: float = 0.0) -> np.ndarray:
    """A(xi) of (A4) from the coefficients `c`."""
    i = 1j
    return np.array([
        [-i * w0 * xi_v, 0, -i * phi_v * xi_v],
        [i * c["a1"] * xi_v, -c["b11"] * xi_v**2 - i * w0 * xi_v, -c["b12"] * xi_v**2],
        [i * c["a2"] * xi_v, -c["b21"] * xi_v**2, -c["b22"] * xi_v**2 - i * w0 * xi_v],
    ], dtype=complex)


def gamma(c: dict) -> np.ndarray:
    """Gamma of (A5)."""
    return np.array([[c["b11"], c["b12"]], [c["b21"], c["b22"]]])


@dataclass
class StabilityNumbers:
    """Item-7 numbers for one rheology and base state."""

    rheology: str
    phi: float
    uz: float
    wz: float
    xi: float
    M: float
    chi: float
    trace_gamma: float
    det_gamma: float
    lambda_plus: complex
    lambda_minus: complex
    max_re_eig_over_xi2: float
    lambda0_limit: float

    def to_json(self) -> dict:
        out = asdict(self)
        for k in ("lambda_plus", "lambda_minus"):
            z = complex(out[k])
            out[k] = z.real if abs(z.imag) <= 1e-14 * max(1.0, abs(z)) else {"re": z.real, "im": z.imag}
        return out


def stability_numbers(name: str, phi: float, uz: float, wz: float, xi: float = 1e4,
                      material=None) -> StabilityNumbers:
    """M, chi (A18), tr/det Gamma, Lambda_pm (A9), max Re eig A(xi)/xi^2 and -C/B for one state.

    Lambda_pm are the roots (A9) of (A8) for this rheology's Gamma (lambda_plus has the larger
    real part); -C/B = phi (a2 b11 - a1 b21)/det Gamma (derived in :mod:`stability.linearize`).
    Raises ValueError for phi outside (0, phi_c), xi <= 0, non-finite or zero (u_z, w_z).
    """
    phi_v, uz_v, wz_v, xi_v = phi, uz, wz, xi
    xi_v = check_xi(xi_v)
    c = coefficients(name, phi_v, uz_v, wz_v, material)
    G = gamma(c)
    tr, det = float(np.trace(G)), float(np.linalg.det(G))
    disc = complex(tr * tr - 4 * det)
    r = np.sqrt(disc)
    lp, lm = (-tr + r) / 2, (-tr - r) / 2
    if lp.real < lm.real:
        lp, lm = lm, lp
    ev = np.linalg.eigvals(A_matrix(c, float(phi_v), xi_v))
    lim = float(phi_v) * (c["a2"] * c["b11"] - c["a1"] * c["b21"]) / det   # -C/B, see linearize
    with np.errstate(divide="ignore", invalid="ignore"):
        chi_v = float(chi(phi_v, uz_v, wz_v, material))
    return StabilityNumbers(name, float(phi_v), float(uz_v), float(wz_v), xi_v,
                            float(M_numeric(phi_v, material)), chi_v, tr, det,
                            complex(lp), complex(lm), float(ev.real.max() / xi_v**2), lim)
