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

The case is py-pde-free (:class:`.core.PlaneCells`):
a run imports neither py-pde, numba nor scipy.
"""

from __future__ import annotations

import numpy as np

from .cell import Plane2D
from .core import PlaneCells
from ...cvode_settings import KRYLOV_DIM, KRYLOV_EPS_LIN
from ...native.build import NativeUnavailable
from ...native import NativeProblem, _pointer

__all__ = ["Plane2DProblem", "Plane2DCase", "LINEAR_SOLVER"]

#: what the engine reports as its linear solver (:data:`icidr_pde.engines.choose.NATIVE_SCHEMES`)
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


class Plane2DCase:
    """A 2-D case on the native engine: the scene's data on the cells of
    :class:`~.core.PlaneCells` (grid, walls, mass,
    validity), with the engine's state vector the data flattened."""

    discretization = "fv2d"

    def __init__(self, rheology, scene, N, *, material=None, advection=None, scene_params=None):
        from ...case import _law
        from ...scenes import get_scene

        self.scene = get_scene(scene, **(scene_params or {}))
        if getattr(self.scene, "dim", 1) != 2:
            raise NativeUnavailable("a 1-D scene")
        law = _law(rheology, material)
        law.material.check_phi(self.scene.phi0, "phi0")
        options = {} if advection is None else {"advection": advection}
        self.cells = PlaneCells(law, N, self.scene.H, L=self.scene.L, **options)  # the walls' V0 as py-pde's case
        self.rheology, self.advection = self.cells.rheology, self.cells.advection
        self.N, self.Nx, self.L, self.H, self.V0 = self.cells.Nz, self.cells.Nx, self.cells.L, self.cells.H, self.cells.V0
        self.z = self.cells.nodes()
        self.y0 = self.cells.initial_data(*self.scene.initial_condition(self.z)).ravel()

    def problem(self) -> Plane2DProblem:
        c = self.cells
        return Plane2DProblem(self.rheology, c.Nx, c.Nz, c.hx, c.hz, advection=self.advection, V0=c.V0)

    def fields(self, y) -> np.ndarray:
        """(3, Nx, Nz) fields of the state vector `y`."""
        return self.cells.unpack(y)

    def phi(self, y) -> np.ndarray:
        return self.fields(y)[0]

    def mass(self, data) -> float:
        return self.cells.mass(data)

    def check_state(self, y) -> str | None:
        """Why the state `y` is invalid (as the stiff solver's check), or None."""
        if not np.all(np.isfinite(y)):
            return "state became non-finite"
        return self.cells.check_state(self.fields(y))

    def plane(self, data) -> dict:
        """The Result's grid and per-snapshot measures of the snapshots `data` (as the py-pde path's)."""
        return Plane2D.registered().result_extras(self, data)
