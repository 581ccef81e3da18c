"""CVODE's left preconditioners of the 2-D cell's Newton systems, with the mass kept exactly.

A preconditioner of (I - gamma J) is given as two callables, a set-up (when CVODE asks for one,
with or without a new Jacobian) and a solve; :func:`mass_keeping_precond` wraps them as
scikit-sundae's ``CVODEPrecond`` and makes the solve keep the conserved quantity.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mass_keeping_precond", "jacobian_precond"]


def jacobian_precond(jac, build, weights=None):
    """CVODE's left preconditioner built from the analytic Jacobian.

    Args:
        jac: the analytic sparse Jacobian jac(t, y)
        build: build(J, gamma) -> an inverse of I - gamma J, or its approximation, with methods
            ``at(gamma)`` (the same J at another gamma) and ``solve(r, out)`` (z into `out`)
        weights: the mass weights c (c J = 0), or None (:func:`mass_keeping_precond`)

    J, and what is built from it, is rebuilt when CVODE asks for a new Jacobian (jok false);
    otherwise only gamma is updated.
    """
    saved = {}

    def setup(t, y, gamma, jok):
        if not jok or "inverse" not in saved:
            J = jac(t, np.array(y))
            saved.pop("inverse", None)  # the previous inverse's memory is free before the next is built
            saved["inverse"] = build(J, gamma)
            return True
        saved["inverse"].at(gamma)
        return False

    def solve(r, z):
        saved["inverse"].solve(r, out=z)

    return mass_keeping_precond(setup, solve, weights)


def mass_keeping_precond(setup, solve, weights=None):
    """CVODE's left preconditioner (scikit-sundae's CVODEPrecond) from `setup` and `solve`.

    Args:
        setup: setup(t, y, gamma, jok) -> whether it evaluated a new Jacobian (jok: CVODE allows
            the previous one)
        solve: solve(r, z) writes the preconditioner's z = P^-1 r into z
        weights: the mass weights c (c J = 0) of the conserved quantity, or None

    With `weights`, z is corrected by a multiple of q (c q = 1, q on the support of c) so that
    c z = c r: then c P^-1 = c, the Krylov vectors keep c . v = 0 and the Newton corrections the
    mass to round-off.
    """
    from sksundae.cvode import CVODEPrecond

    if weights is not None:
        support = np.flatnonzero(weights)
        if support.size and np.all(np.diff(support) == 1):  # a slice: no copies of the vectors
            support = slice(support[0], support[-1] + 1)
        c = np.asarray(weights, dtype=float)[support]
        q = c / np.sum(c * c)

    def psetup(t, y, yp, jok, jnew, gamma):
        jnew[0] = 1 if setup(t, y, gamma, jok) else 0

    def psolve(t, y, yp, r, z, gamma, delta, lr):
        solve(r, z)
        if weights is not None:  # sums, not BLAS dot products: OpenBLAS's threads stall a loaded machine
            z[support] += np.sum(c * (r[support] - z[support])) * q

    return CVODEPrecond(psetup, psolve, side="left")
