"""Constitutive laws of the shear cell, written once for every discretization.

Everything here is non-dimensional with the scalings (3.12): d = rho_* = V0 = 1.
The stress kernels are written in numpy style (element-wise on arrays, no Python
branches) so that the same source runs under numpy and compiles under numba.

Material functions (Schaeffer et al. 2019):

.. math::
    \\mu(I) = \\mu_s + \\frac{\\mu_d - \\mu_s}{I_0/I + 1} \\quad (2.10), \\qquad
    \\Phi(I) = \\phi_c - a I \\quad (2.11), \\qquad
    \\Psi(\\phi) = (\\phi_c - \\phi)/a \\quad (2.13), \\qquad M(\\phi) = \\mu(\\Psi(\\phi)).

Shear-cell stresses, with strain rates u_z, w_z (deviatoric strain rate (3.4),
||S||^2 = (u_z^2 + w_z^2)/4 by (3.5), div u = w_z):

* mu(I),Phi(I): p = (u_z^2 + w_z^2)/Psi^2 (3.6) and
  tau = M p (u_z, w_z)/sqrt(u_z^2 + w_z^2) (3.8).
* iCIDR: (4.12) with div u = w_z gives p = (2/(M Psi))^2 G^2 with
  G = sqrt(w_z^2 + M^2 (u_z^2 + w_z^2)/4) - w_z. The transcription's (5.1)/(5.6)
  square the bracket (u_z^2 + w_z^2) inside the root; that is a transcription error
  (see ``stability`` for the derivation). From (4.14), tau = (M/Psi) sqrt(p) (u_z, w_z)
  = (2 G/Psi^2) (u_z, w_z), since sqrt(p) = 2 G/(M Psi) and G >= 0.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numba.extending import register_jitable

__all__ = [
    "Material",
    "Rheology",
    "MuIPhiI",
    "ICIDR",
    "RHEOLOGIES",
    "get_rheology",
    "friction",
    "inertial_number_of_phi",
    "chi",
]


@dataclass(frozen=True)
class Material:
    """Material parameters of (2.10)-(2.11); defaults are the paper's Table 1.

    Args:
        mu_s: static friction coefficient, 0 < mu_s < mu_d
        mu_d: dynamic (large-I) friction coefficient, mu_s < mu_d < 1
        I0: inertial-number scale of (2.10), I0 > 0
        phi_c: critical (jamming) packing fraction, 0 < phi_c < 1
        a: slope of Phi(I) in (2.11), a > 0
    """

    mu_s: float = 0.248
    mu_d: float = 0.588
    I0: float = 0.145
    phi_c: float = 0.817
    a: float = 0.314

    def __post_init__(self):
        for name in ("mu_s", "mu_d", "I0", "phi_c", "a"):
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating)) or not math.isfinite(value):
                raise ValueError(f"Material parameter `{name}` must be a finite number, got {value!r}")
        if not 0 < self.mu_s < self.mu_d:
            raise ValueError(
                f"`mu_s` must lie in (0, mu_d) = (0, {self.mu_d}); got mu_s={self.mu_s}"
            )
        if not self.mu_d < 1:
            # M < 1 is what makes chi (A18) and the alignment law meaningful
            raise ValueError(f"`mu_d` must lie in (mu_s, 1) = ({self.mu_s}, 1); got {self.mu_d}")
        if not self.I0 > 0:
            raise ValueError(f"`I0` must be > 0; got {self.I0}")
        if not 0 < self.phi_c < 1:
            raise ValueError(f"`phi_c` must lie in (0, 1); got {self.phi_c}")
        if not self.a > 0:
            raise ValueError(f"`a` must be > 0; got {self.a}")

    @property
    def params(self) -> tuple[float, float, float, float, float]:
        """Parameters as a plain tuple, the form compiled kernels take."""
        return (float(self.mu_s), float(self.mu_d), float(self.I0), float(self.phi_c), float(self.a))

    def to_dict(self) -> dict:
        return asdict(self)

    def check_phi(self, phi, name: str = "phi") -> np.ndarray:
        """Return `phi` as an array, raising if it leaves the inertial range (0, phi_c)."""
        phi = np.asarray(phi, dtype=float)
        if not np.all(np.isfinite(phi)) or np.any(phi <= 0) or np.any(phi >= self.phi_c):
            shown = f"[{phi.min():g}, {phi.max():g}]" if np.all(np.isfinite(phi)) else "non-finite values"
            raise ValueError(f"`{name}` must lie in (0, phi_c) = (0, {self.phi_c}); got {shown}")
        return phi

    def mu(self, I):
        """Friction coefficient mu(I), (2.10)."""
        return friction(np.asarray(I, dtype=float), self.mu_s, self.mu_d, self.I0)

    def Phi(self, I):
        """Steady packing fraction Phi(I) = phi_c - a I, (2.11)."""
        return self.phi_c - self.a * np.asarray(I, dtype=float)

    def Psi(self, phi):
        """Inverse of Phi: I = Psi(phi) = (phi_c - phi)/a, (2.13)."""
        return inertial_number_of_phi(np.asarray(phi, dtype=float), self.phi_c, self.a)

    def M(self, phi):
        """M(phi) = mu(Psi(phi)), (A11a)."""
        return self.mu(self.Psi(phi))


# --- element-wise kernels: plain Python for numpy, register_jitable for numba -----------------------------------------


@register_jitable
def friction(I, mu_s, mu_d, I0):
    """mu(I) of (2.10), written as mu_s + (mu_d - mu_s) I/(I0 + I) (finite at I = 0)."""
    return mu_s + (mu_d - mu_s) * I / (I0 + I)


@register_jitable
def friction_derivative(I, mu_s, mu_d, I0):
    """d mu/d I of (2.10)."""
    return (mu_d - mu_s) * I0 / (I0 + I) ** 2


@register_jitable
def inertial_number_of_phi(phi, phi_c, a):
    """Psi(phi) of (2.13)."""
    return (phi_c - phi) / a


@register_jitable
def _material_functions(phi, params):
    """Return M, dM/dphi, k = 1/Psi^2 and dk/dphi at packing fraction `phi`."""
    mu_s, mu_d, I0, phi_c, a = params
    psi = (phi_c - phi) / a
    M = friction(psi, mu_s, mu_d, I0)
    dM = -friction_derivative(psi, mu_s, mu_d, I0) / a
    k = 1.0 / (psi * psi)
    dk = 2.0 / (a * psi * psi * psi)
    return M, dM, k, dk


@register_jitable
def mui_stress(phi, uz, wz, params):
    """p, tau_xz, tau_zz of the mu(I),Phi(I)-rheology in the shear cell, (3.6), (3.8)."""
    M, _, k, _ = _material_functions(phi, params)
    q = np.sqrt(uz * uz + wz * wz)
    p = k * q * q
    c = M * k * q
    return p, c * uz, c * wz


@register_jitable
def mui_stress_jacobian(phi, uz, wz, params):
    """Partial derivatives of :func:`mui_stress` with respect to (phi, u_z, w_z).

    Returns nine arrays: dp/dphi, dp/duz, dp/dwz, dtxz/dphi, ..., dtzz/dwz.
    Where u_z = w_z = 0 the stress is not differentiable; the terms in 1/q are set to 0.
    """
    M, dM, k, dk = _material_functions(phi, params)
    q2 = uz * uz + wz * wz
    q = np.sqrt(q2)
    inv_q = np.where(q > 0, 1.0 / np.where(q > 0, q, 1.0), 0.0)
    c = M * k
    dc = dM * k + M * dk
    p_phi, p_uz, p_wz = dk * q2, 2 * k * uz, 2 * k * wz
    txz_phi = dc * q * uz
    txz_uz = c * (q + uz * uz * inv_q)
    txz_wz = c * uz * wz * inv_q
    tzz_phi = dc * q * wz
    tzz_uz = txz_wz
    tzz_wz = c * (q + wz * wz * inv_q)
    return p_phi, p_uz, p_wz, txz_phi, txz_uz, txz_wz, tzz_phi, tzz_uz, tzz_wz


@register_jitable
def _icidr_gap(M, uz, wz):
    """G = sqrt(w_z^2 + M^2 ||2S||^2/4) - w_z >= 0 and the root R, free of cancellation.

    For w_z > 0 the difference is rewritten as M^2 s^2/(R + w_z), s^2 = ||S||^2, so
    G = 0 exactly on the zero-pressure set (4.13): ||S|| = 0 and div u = w_z >= 0.
    """
    m2s2 = 0.25 * M * M * (uz * uz + wz * wz)
    R = np.sqrt(wz * wz + m2s2)
    plus = R + np.abs(wz)
    safe = np.where(plus > 0, plus, 1.0)
    G = np.where(wz > 0, m2s2 / safe, plus)
    return G, R


@register_jitable
def icidr_stress(phi, uz, wz, params):
    """p, tau_xz, tau_zz of iCIDR in the shear cell, from (4.12) and (4.14) with div u = w_z."""
    M, _, k, _ = _material_functions(phi, params)
    G, _ = _icidr_gap(M, uz, wz)
    p = 4.0 * k * G * G / (M * M)
    c = 2.0 * k * G
    return p, c * uz, c * wz


@register_jitable
def icidr_stress_jacobian(phi, uz, wz, params):
    """Partial derivatives of :func:`icidr_stress` with respect to (phi, u_z, w_z).

    G is Lipschitz but not differentiable at u_z = w_z = 0; there the root R is given
    zero derivative (dG/dw_z = -1, the mean of the two one-sided slopes along u_z = 0).
    """
    M, dM, k, dk = _material_functions(phi, params)
    G, R = _icidr_gap(M, uz, wz)
    s2 = 0.25 * (uz * uz + wz * wz)
    inv_R = np.where(R > 0, 1.0 / np.where(R > 0, R, 1.0), 0.0)
    G_phi = M * dM * s2 * inv_R
    G_uz = 0.25 * M * M * uz * inv_R
    G_wz = (1.0 + 0.25 * M * M) * wz * inv_R - 1.0
    inv_M2 = 1.0 / (M * M)
    p_phi = 4.0 * inv_M2 * (dk * G * G + 2.0 * k * G * G_phi - 2.0 * k * G * G * dM / M)
    p_uz = 8.0 * inv_M2 * k * G * G_uz
    p_wz = 8.0 * inv_M2 * k * G * G_wz
    c = 2.0 * k * G
    c_phi = 2.0 * (dk * G + k * G_phi)
    c_uz = 2.0 * k * G_uz
    c_wz = 2.0 * k * G_wz
    txz_phi, txz_uz, txz_wz = c_phi * uz, c_uz * uz + c, c_wz * uz
    tzz_phi, tzz_uz, tzz_wz = c_phi * wz, c_uz * wz, c_wz * wz + c
    return p_phi, p_uz, p_wz, txz_phi, txz_uz, txz_wz, tzz_phi, tzz_uz, tzz_wz


def chi(phi, uz, wz, params):
    """Ill-posedness indicator chi of (A18): chi > 0 ill-posed, chi < 0 well-posed.

    chi = w_z/|u_z| - M/sqrt(1 - M^2); +inf where u_z = 0 and w_z > 0 (and also where
    u_z = 0, w_z = 0 is treated as ill-posed as in the paper's fig 7(d)).
    """
    mu_s, mu_d, I0, phi_c, a = params
    M = friction((phi_c - phi) / a, mu_s, mu_d, I0)
    au = np.abs(uz)
    ratio = np.where(au > 0, wz / np.where(au > 0, au, 1.0), np.where(wz < 0, -np.inf, np.inf))
    return ratio - M / np.sqrt(1.0 - M * M)


# --- rheology objects -----------------------------------------------------------------


class Rheology:
    """A constitutive law of the shear cell: stresses as functions of (phi, u_z, w_z).

    Subclasses name the element-wise kernels; :meth:`stress` and :meth:`stress_jacobian`
    evaluate them with numpy, and the discretizations compile the same kernels with numba.
    """

    name: str = ""
    label: str = ""
    stress_kernel = None
    jacobian_kernel = None

    def __init__(self, material: Material | None = None):
        self.material = Material() if material is None else material
        if not isinstance(self.material, Material):
            raise TypeError("`material` must be an icidr_pde.rheology.Material")

    def __repr__(self) -> str:
        return f"{self.__class__.__name__}({self.material!r})"

    def _inputs(self, phi, uz, wz):
        phi, uz, wz = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (phi, uz, wz)))
        self.material.check_phi(phi)
        for name, value in (("uz", uz), ("wz", wz)):
            if not np.all(np.isfinite(value)):
                raise ValueError(f"`{name}` must be finite")
        return phi, uz, wz

    def stress(self, phi, uz, wz):
        """Return (p, tau_xz, tau_zz) for arrays of phi in (0, phi_c), u_z and w_z."""
        phi, uz, wz = self._inputs(phi, uz, wz)
        return type(self).stress_kernel(phi, uz, wz, self.material.params)

    def stress_jacobian(self, phi, uz, wz):
        """Return the nine partial derivatives of (p, tau_xz, tau_zz) by (phi, u_z, w_z)."""
        phi, uz, wz = self._inputs(phi, uz, wz)
        return type(self).jacobian_kernel(phi, uz, wz, self.material.params)

    def momentum_flux(self, phi, uz, wz):
        """Fluxes of the momentum equations: (tau_xz, tau_zz - p)."""
        p, txz, tzz = self.stress(phi, uz, wz)
        return txz, tzz - p

    def chi(self, phi, uz, wz):
        """chi of (A18) at these states (meaningful as an ill-posedness test for mu(I))."""
        return chi(np.asarray(phi, float), np.asarray(uz, float), np.asarray(wz, float),
                   self.material.params)


class MuIPhiI(Rheology):
    """The compressible mu(I),Phi(I)-rheology, (2.6)-(2.8), in the shear cell (3.6), (3.8)."""

    name = "mui"
    label = r"$\mu(I),\Phi(I)$"
    stress_kernel = staticmethod(mui_stress)
    jacobian_kernel = staticmethod(mui_stress_jacobian)


class ICIDR(Rheology):
    """Inertial CIDR, (4.7)-(4.8), with local pressure (4.12) and stress (4.14)."""

    name = "icidr"
    label = "iCIDR"
    stress_kernel = staticmethod(icidr_stress)
    jacobian_kernel = staticmethod(icidr_stress_jacobian)


RHEOLOGIES = {cls.name: cls for cls in (MuIPhiI, ICIDR)}


def get_rheology(name: str | Rheology, material: Material | None = None) -> Rheology:
    """Return the rheology called `name` ('mui' or 'icidr')."""
    if isinstance(name, Rheology):
        return name
    try:
        cls = RHEOLOGIES[name]
    except KeyError:
        raise ValueError(
            f"`rheology` must be one of {sorted(RHEOLOGIES)}; got {name!r}"
        ) from None
    return cls(material)
