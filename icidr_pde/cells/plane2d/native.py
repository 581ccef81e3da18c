"""The 2-D cell (``fv2d``) on the native engine: its rates in C, CVODE with matrix-free GMRES.

The rates are the numba template ``templates/plane2d.py`` printed as C
(:mod:`icidr_pde.native.translate`: the whole grid as one patch, ``halo_into`` then ``patch_rates``), in a
library of the law of plane flow (:mod:`icidr_pde.native.build`). CVODE is set up as the py-pde path sets it
up on a thick cell (:mod:`icidr_pde.engines.sundae`, linear solver 'GMRES'): BDF, SUNDIALS'
GMRES of Krylov dimension :data:`icidr_pde.cvode_settings.KRYLOV_DIM` without a preconditioner, the tolerance factor
:data:`icidr_pde.cvode_settings.KRYLOV_EPS_LIN`, CVODE's difference-quotient products J v;
the mass stays the exact solves' to round-off as on that path (the rates of phi are flux
differences, so every product J v has zero mass up to round-off). A thin cell (hx > THIN_CELL hz),
where the py-pde path preconditions along z, is not taken here (:func:`icidr_pde.engines.choose.choose`).

The case is the run path's on the py-pde-free core :class:`.core.PlaneCells` (:func:`plane2d_problem`):
a run imports neither py-pde, numba nor scipy.
"""

from __future__ import annotations


import numpy as np

from ...cvode_settings import KRYLOV_DIM, KRYLOV_EPS_LIN
from ...native.build import NativeUnavailable
from ...native import NativeProblem, _pointer

__all__ = ["Plane2DProblem", "plane2d_problem", "LINEAR_SOLVER"]

#: what the engine reports as its linear solver (the descriptor's ``native``, :mod:`.cell`)
LINEAR_SOLVER = "GMRES"


class Plane2DProblem(NativeProblem):
    """The compiled 2-D problem of `rheology` on the Nx x Nz cells of widths hx, hz: rates of the
    state vector (the data (3, Nx, Nz) flattened), M(phi) and CVODE with GMRES; valid while
    lo < phi < hi, `bounds` (default: the law's range of phi). ``N`` is the number of cells."""

    kernel_repeats = 50
    linear_solver = "gmres"
    #: the largest t_end / (fastest time scale) its GMRES without a preconditioner follows: beyond it
    #: Newton's solves stop converging as the steps grow (iCIDR bump2d 24^2 with H = L scaled down
    #: failed at t / tau = 8.5e9 for H = 0.1 and H = 0.03 alike, ran at H = 0.3; a margin of 85)
    max_stiffness = 1e8

    def __init__(self, rheology, Nx: int, Nz: int, hx: float, hz: float, *, advection: str = "central",
                 V0: float = 1.0, bounds=None, eps_lin: float | None = None, krylov_dim: int = KRYLOV_DIM):
        from ...discretizations.core import ghost_coefficients
        from ...rheology import PLANE_FLOW

        params, lo, hi = self._open(rheology, bounds, PLANE_FLOW)
        self.Nx, self.Nz, self.N = int(Nx), int(Nz), int(Nx) * int(Nz)
        self.hx, self.hz = float(hx), float(hz)
        self.eps_lin = KRYLOV_EPS_LIN if eps_lin is None else float(eps_lin)
        self.ghost = np.ascontiguousarray(ghost_coefficients(V0))
        handle = self.lib.icidr_plane2d_problem(self.Nx, self.Nz, self.hx, self.hz, int(advection == "upwind"),
                                             _pointer(self.ghost), _pointer(params), params.size, lo, hi,
                                             int(krylov_dim), self.eps_lin)
        if not handle:
            raise NativeUnavailable("the 2-D native problem needs SUNDIALS' GMRES (SPGMR), not found")
        self._attach(handle)

    def counts(self) -> dict:
        """CVODE's counts, the right-hand sides of its products J v included (as the py-pde path counts them)."""
        counts = super().counts()
        counts["rhs"] += self.krylov_counts()["jv_rhs"]
        return counts

    def krylov_counts(self) -> dict:
        """GMRES iterations, their convergence failures and the products J v (with their right-hand sides)."""
        import ctypes

        out = (ctypes.c_long * 6)()
        self.lib.icidr_krylov_counts(self.handle, out)
        return dict(zip(("iterations", "convergence_failures", "prec_setups", "prec_solves", "jv",
                         "jv_rhs"), map(int, out)))


def plane2d_problem(case, **options) -> Plane2DProblem:
    """The compiled problem of the run path's 2-D case `case` (its core :class:`.core.PlaneCells`)."""
    c = case.scheme
    return Plane2DProblem(case.rheology, c.Nx, c.Nz, c.hx, c.hz, advection=c.advection, V0=c.V0, **options)
