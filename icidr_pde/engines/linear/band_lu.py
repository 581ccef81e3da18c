"""Band LU of the Newton matrix: CVODE's on the analytic band Jacobian or on difference
quotients in the band, and LSODA's on its own banded quotients."""

from __future__ import annotations

from .base import JacobianForm, LinearSolver, Memory

__all__ = ["CvodeBandLU", "LsodaBandLU", "conserving_quotients"]


class CvodeBandLU(LinearSolver):
    """CVODE's band LU in the scheme's banded ordering: 'analytic' where the scheme writes its
    analytic Jacobian into the band (``make_band_jacobian``), 'banded-fd' difference quotients
    (2 * band + 1 right-hand sides a Jacobian) with exact mass-row column sums."""

    name = "band LU"
    modes = ("analytic", "banded-fd")
    methods = ("CVODE",)
    preference = 10
    form = JacobianForm("banded")
    petsc = ("preonly", "lu")

    def offered(self, mode, structure):
        return structure.band_jac if mode == "analytic" else structure.banded

    def memory(self, n, method, mode, thin=False):
        if mode != "analytic":  # the quotients are handed over densely too, but only up to 256 MiB
            return Memory(0.0, "", repr(mode))
        return Memory(8.0 * n * n, f"1 dense {n} x {n} array: scikit-sundae's dense hand-over array of the band "
                      "Jacobian", "'analytic' (band)",
                      "; the native engine and method 'BDF' need no dense array")

    def cvode_options(self, problem, rtol, atol):
        jacobian = problem.jacobian
        kwargs = dict(linsolver="band", lband=jacobian.band[0], uband=jacobian.band[1])
        if jacobian.band_jac is not None:
            jac_into = jacobian.band_jac

            def jacfn(t, y, yp, JJ):  # JJ: (n, n), CVODE copies its band
                jac_into(y, JJ)

            kwargs["jacfn"] = jacfn
        else:
            jacfn = conserving_quotients(problem, jacobian.band, rtol, atol)
            if jacfn is not None:
                kwargs["jacfn"] = jacfn
        return kwargs


class LsodaBandLU(LinearSolver):
    """LSODA's band LU on its banded difference quotients (scipy's ``lband``, ``uband``)."""

    name = "band LU (LSODA)"
    modes = ("banded-fd",)
    methods = ("LSODA",)
    engine = "scipy"
    preference = 10
    form = JacobianForm("banded")


def conserving_quotients(problem, band, rtol, atol):
    """Difference quotients with exact mass-row column sums (:mod:`..conservative_jacobian`) as
    scikit-sundae's jacfn, or None where the scheme has no weights or the dense hand-over array
    would pass 256 MiB (then SUNDIALS' own quotients)."""
    from ..conservative_jacobian import ConservativeDifferenceQuotients

    jacobian, n = problem.jacobian, len(problem.y0)
    if jacobian.weights is None or 8 * n * n > 2**28:
        return None
    dq = ConservativeDifferenceQuotients(problem.fun, jacobian.weights, jacobian.anchor, band, floor=atol / rtol)

    def jacfn(t, y, yp, JJ):  # scikit-sundae hands a dense n x n array, even for 'band'
        dq.fill(t, y, JJ)

    return jacfn
