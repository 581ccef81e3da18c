"""The 1-D shear cell on the native engine: its case and the compiled finite-volume problem.

:class:`NativeCase` is a 1-D case (:func:`icidr_pde.case.build_case`'s scene and scheme core);
:class:`FdProblem` binds the C of ``problem.c`` (finite volumes: the right-hand side and the
analytic band Jacobian printed from ``templates/fd.py``) for CVODE (:mod:`icidr_pde.native`).
The walls are the ghost-cell maps of :func:`icidr_pde.discretizations.core.ghost_coefficients`
(a test compares them with py-pde's boundary setters); the grid is py-pde's cell-centred
``CartesianGrid([[0, H]], N)``. The Chebyshev problem is :mod:`.native_cheb`.
"""

from __future__ import annotations

import numpy as np

from ...discretizations.core import ghost_coefficients
from ...discretizations.grid_size import FD
from ...native import NativeProblem, _pointer
from ...native.build import NativeUnavailable

__all__ = ["FdProblem", "FdCase", "NativeCase", "MAX_N"]

MAX_N = FD.max_N


class FdProblem(NativeProblem):
    """The compiled finite-volume problem of `rheology` on N cells of height H (interleaved
    vector y[3 i + k]): right-hand side, band Jacobian, M(phi), and CVODE; valid while
    lo < phi < hi, `bounds` (default: the law's range of phi).

    The band is ``jb[col, row - col + 5]`` (11 entries a column, :meth:`jacobian_band`);
    :meth:`jacobian_dense` spreads it into the (3N, 3N) matrix."""

    def __init__(self, rheology, N: int, H: float, *, advection: str = "upwind", V0: float = 1.0, bounds=None):
        from ...rheology import SHEAR_CELL

        params, lo, hi = self._open(rheology, bounds, SHEAR_CELL)
        self.N, self.H, self.h = int(N), float(H), float(H) / int(N)
        self.ghost = np.ascontiguousarray(ghost_coefficients(V0))
        self._attach(self.lib.icidr_fd_problem(self.N, self.h, int(advection == "upwind"), _pointer(self.ghost),
                                               _pointer(params), params.size, lo, hi))

    def jacobian_band(self, y) -> np.ndarray:
        y = np.ascontiguousarray(y, dtype=float)
        jb = np.empty((3 * self.N, 11))
        self.lib.icidr_fd_jacobian(self.handle, _pointer(y), _pointer(jb))
        return jb

    def jacobian_dense(self, y) -> np.ndarray:
        jb, n = self.jacobian_band(y), 3 * self.N
        J = np.zeros((n, n))
        for offset in range(-5, 6):
            cols = np.arange(max(0, -offset), min(n, n - offset))
            J[cols + offset, cols] = jb[cols, offset + 5]
        return J


class NativeCase:
    """A 1-D case on the native engine: :func:`icidr_pde.case.build_case`'s scene and scheme
    core (its checks, nodes, walls, initial data, quadrature, strain rates and validity), with
    the engine's state vector y (the core's ``pack``: interleaved for fd, blocks for cheb)."""

    discretization = ""

    def __init__(self, rheology, scene, N, *, material=None, advection=None, scene_params=None):
        from ...case import build_case
        from ...scenes import get_scene

        if getattr(get_scene(scene, **(scene_params or {})), "dim", 1) != 1:
            raise NativeUnavailable("a 2-D scene")
        options = {} if advection is None else {"advection": advection}
        case = build_case(rheology, scene, self.discretization, N, material=material, options=options,
                          scene_params=scene_params)
        self.scheme, self.scene = case.scheme, case.scene
        self.rheology, self.N, self.H, self.V0 = self.scheme.rheology, self.scheme.N, self.scheme.H, self.scheme.V0
        self.z = self.scheme.z
        self.advection = self.scheme.option_values.get("advection")
        self.y0 = self.scheme.pack(case.data)

    def fields(self, y) -> np.ndarray:
        """(3, N) fields of the state vector `y`."""
        return self.scheme.unpack(y)

    def phi(self, y) -> np.ndarray:
        return self.scheme.phi_of(y)

    def mass(self, data) -> float:
        """The scheme's integral of phi."""
        return self.scheme.mass(data)

    def strain_rates(self, data):
        """Where the stresses live and (phi, u_z, w_z) there."""
        return self.scheme.strain_rates(data)

    def check_state(self, y) -> str | None:
        """Why the state `y` is invalid (as the stiff solver's check), or None."""
        if not np.all(np.isfinite(y)):
            return "state became non-finite"
        return self.scheme.check_state(self.fields(y))


class FdCase(NativeCase):
    """A finite-volume case (``discretization="fd"``, option ``advection``) on the native engine."""

    discretization = "fd"

    def problem(self) -> FdProblem:
        return FdProblem(self.rheology, self.N, self.H, advection=self.advection, V0=self.V0)
