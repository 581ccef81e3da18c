"""Dense LU of the Newton matrix: LAPACK's on the analytic Jacobian, SUNDIALS' on difference
quotients, scipy's and LSODA's."""

from __future__ import annotations

from ...cvode_settings import DENSE_LU_DELTA_GAMMA
from .band_lu import conserving_quotients
from .base import LinearSolver, Memory

__all__ = ["CvodeDenseLU", "CvodeDenseQuotients", "ScipyDenseLU", "LsodaDenseLU"]


def _dense_arrays(n: int, count: int, mode: str, note: str) -> Memory:
    """`count` dense n x n arrays holding `note`."""
    return Memory(8.0 * count * n * n, f"{count} dense {n} x {n} array{'s' if count > 1 else ''}: {note}", repr(mode))


class CvodeDenseLU(LinearSolver):
    """LAPACK's dense LU on the analytic Jacobian (a scheme without a band: Chebyshev), kept until
    gamma has changed by :data:`~icidr_pde.engines.base.DENSE_LU_DELTA_GAMMA`."""

    name = "dense LU (LAPACK)"
    modes = ("analytic",)
    methods = ("CVODE",)
    preference = 20
    # a dense LU (Chebyshev: 603 x 603) costs many RHS calls (docs/chebyshev.md): keep the factored
    # I - gamma J until gamma has doubled (modified Newton), not only changed by 30 %
    delta_gamma = DENSE_LU_DELTA_GAMMA

    def cvode_options(self, problem, rtol, atol):
        from ..base import dense

        dense_jac = dense(problem.jacobian.jac)

        def jacfn(t, y, yp, JJ):  # scikit-sundae reads this signature: no extra arguments
            JJ[:, :] = dense_jac(t, y)

        return dict(linsolver="lapackdense", jacfn=jacfn)


class CvodeDenseQuotients(LinearSolver):
    """SUNDIALS' dense LU on difference quotients (for comparison only)."""

    name = "dense LU"
    modes = ("none",)
    methods = ("CVODE",)
    preference = 80

    def memory(self, n, method, mode, thin=False):
        return _dense_arrays(n, 2, mode, "CVODE's dense matrix and its saved Jacobian")

    def cvode_options(self, problem, rtol, atol):
        jacfn = conserving_quotients(problem, None, rtol, atol)
        return {} if jacfn is None else dict(jacfn=jacfn)


class ScipyDenseLU(LinearSolver):
    """scipy's BDF and Radau on a dense Jacobian: the analytic one of a dense scheme, or
    difference quotients ('none')."""

    name = "dense LU (LAPACK)"
    modes = ("analytic", "sparse-fd", "colored-fd", "none")
    methods = ("BDF", "Radau")
    engine = "scipy"
    preference = 20

    def memory(self, n, method, mode, thin=False):
        if mode != "none":
            return Memory(0.0, "", repr(mode))
        if method == "Radau":
            return _dense_arrays(n, 4, mode, "scipy's dense Jacobian, its real and complex LU")
        return _dense_arrays(n, 2, mode, "scipy's dense Jacobian and its LU")


class LsodaDenseLU(LinearSolver):
    """LSODA's dense LU on the analytic Jacobian or on its own difference quotients ('none')."""

    name = "dense LU (LSODA)"
    modes = ("analytic", "none")
    methods = ("LSODA",)
    engine = "scipy"
    preference = 20

    def memory(self, n, method, mode, thin=False):
        if mode == "none":
            return _dense_arrays(n, 2, mode, "LSODA's dense Jacobian and its LU")
        return _dense_arrays(n, 3, mode, "the dense copy of the Jacobian, LSODA's and its LU")
