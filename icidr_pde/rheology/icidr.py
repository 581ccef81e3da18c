"""Inertial CIDR (4.7)-(4.8): the local pressure (4.12) and the stress (4.14).

With R = sqrt(div_u^2 + M^2 ||S||^2) and the gap G = R - div_u >= 0, (4.12) with
d = rho_* = 1 reads sqrt(p) = 2 G/(M Psi), and (4.14), tau = 2 (M/Psi) sqrt(p) S, gives
c = 4 G/Psi^2. The transcription's (5.1)/(5.6) square the bracket (u_z^2 + w_z^2) inside
the root: a transcription error (``stability`` derives (4.12) from (4.7)-(4.8)).

For div_u > 0 the difference R - div_u cancels in floating point; the `stable` form
rewrites it as M^2 ||S||^2/(R + div_u) (the same function: (R - div)(R + div) = M^2||S||^2),
so G = 0 exactly on the zero-pressure set (4.13), ||S|| = 0 and div u >= 0.
"""

from .base import Rheology

__all__ = ["ICIDR", "gap"]


def gap(div_u, norm_S, M, stable=False):
    """G = sqrt(div_u^2 + M^2 ||S||^2) - div_u >= 0 (Piecewise, cancellation-free if `stable`)."""
    import sympy as sp

    m2s2 = M**2 * norm_S**2
    R = sp.sqrt(div_u**2 + m2s2)
    if not stable:
        return R - div_u
    return sp.Piecewise((m2s2 / (R + div_u), div_u > 0), (R - div_u, True))


class ICIDR(Rheology):
    """Inertial CIDR, (4.7)-(4.8), with local pressure (4.12) and stress (4.14)."""

    name = "icidr"
    label = "iCIDR"

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        G = gap(div_u, norm_S, M, stable)
        p = (2 * G / (M * Psi)) ** 2
        c = 4 * G / Psi**2
        return p, c
