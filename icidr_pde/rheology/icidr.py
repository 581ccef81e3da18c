"""Inertial CIDR (4.7)-(4.8): a CIDR law of the workbench, with the closed form (4.12), (4.14).

The law is its yield function (4.7) Y = M (I/Psi) p and dilatancy function (4.8)
f = (M/4)(I/Psi - Psi/I) (:class:`~.cidr.CIDRLaw`). Solving the flow rule (4.2) with (2.9)
for p gives (4.12); with R = sqrt(div_u^2 + M^2 ||S||^2) and the gap G = R - div_u >= 0 it
reads sqrt(p) = 2 G/(M Psi) (d = rho_* = 1), and (4.14), tau = 2 (M/Psi) sqrt(p) S, gives
c = 4 G/Psi^2. That closed form is what the kernels evaluate; the workbench checks it
against its own solution of the flow rule (:meth:`~.cidr.CIDRLaw.verify_closed_form`).
The transcription's (5.1)/(5.6) square the bracket (u_z^2 + w_z^2) inside the root: a
transcription error (``stability`` derives (4.12) from (4.7)-(4.8)).

For div_u > 0 the difference R - div_u cancels in floating point; the `stable` form
rewrites it as M^2 ||S||^2/(R + div_u) (the same function: (R - div)(R + div) = M^2||S||^2),
so G = 0 exactly on the zero-pressure set (4.13), ||S|| = 0 and div u >= 0.
"""

from .cidr import CIDRLaw

__all__ = ["ICIDR", "gap"]


def gap(div_u, norm_S, M, stable=False):
    """G = sqrt(div_u^2 + M^2 ||S||^2) - div_u >= 0 (Piecewise, cancellation-free if `stable`)."""
    import sympy as sp

    m2s2 = M**2 * norm_S**2
    R = sp.sqrt(div_u**2 + m2s2)
    if not stable:
        return R - div_u
    return sp.Piecewise((m2s2 / (R + div_u), div_u > 0), (R - div_u, True))


class ICIDR(CIDRLaw):
    """Inertial CIDR, (4.7)-(4.8), with local pressure (4.12) and stress (4.14)."""

    name = "icidr"
    rate_homogeneous = True  # p, tau of degree 2 in the strain rate: I is rate-independent
    label = "iCIDR"

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        return M * I / Psi * p                                   # (4.7)

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        return M / 4 * (I / Psi - Psi / I)                       # (4.8)

    def closed_form(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        G = gap(div_u, norm_S, M, stable)
        p = (2 * G / (M * Psi)) ** 2                             # (4.12)
        c = 4 * G / Psi**2                                       # (4.14): tau = c S
        return p, c
