"""The 2-D cell's grid and state without py-pde (``fv2d``): what the native engine needs.

The cells are those of py-pde's ``CartesianGrid([[0, L], [0, H]], [Nx, Nz], periodic=[True,
False])`` (:meth:`.pde.ShearCell2DPDE.make_grid`, which takes its sizes from
:func:`grid_shape`): centres ((i + 1/2) hx, (j + 1/2) hz), data (3, Nx, Nz) of (phi, u, w),
the engines' state vector the data flattened. The walls (3.9) are the 1-D cell's ghost maps
(:func:`icidr_pde.discretizations.core.ghost_coefficients`; a test compares them with py-pde's setters on the 2-D
grid). The scheme itself is ``templates/plane2d.py`` (:mod:`.pde`).
"""

from __future__ import annotations

import math

import numpy as np

from ...rheology import Material, Rheology, get_rheology
from ...discretizations.core import PhiRange, ghost_coefficients
from ...discretizations.grid_size import PLANE2D, check_size
from ...discretizations.registry import check_options

__all__ = ["grid_shape", "PlaneCells", "measures", "DEFAULT_N"]

#: Nz (and Nx) of a 2-D grid when none is given
DEFAULT_N = 64


def grid_shape(N=None, H: float = 30.0, *, L: float | None = None, Nx: int | None = None,
               Nz: int | None = None, default_N: int = DEFAULT_N) -> tuple[int, int, float]:
    """(Nx, Nz, L) of a grid: `N` is Nz (an int) or (Nx, Nz); explicit `Nx`, `Nz` win; Nx
    defaults to Nz and L to H. Refuses sizes below 4 and grids too large for fv2d."""
    if isinstance(N, (tuple, list)):
        N = tuple(N)
        if len(N) != 2:
            raise ValueError(f"`N` must be an integer or a pair (Nx, Nz); got {N}")
        Nx, Nz = Nx if Nx is not None else N[0], Nz if Nz is not None else N[1]
    else:
        if N is not None and (int(N) != N or N < 4):
            raise ValueError(f"`N` must be an integer >= 4 (or a pair (Nx, Nz)); got {N}")
        Nz = Nz if Nz is not None else (default_N if N is None else N)
        Nx = Nz if Nx is None else Nx
    for name, value in (("Nx", Nx), ("Nz", Nz)):
        if int(value) != value or value < 4:
            raise ValueError(f"`{name}` must be an integer >= 4; got {value}")
    L = H if L is None else L
    for name, value in (("H", H), ("L", L)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"`{name}` must be > 0; got {value}")
    Nx, Nz = int(Nx), int(Nz)
    check_size(f"`Nx` x `Nz` = {Nx} x {Nz} = {Nx * Nz} cells is too large for discretization 'fv2d'", Nx * Nz,
               PLANE2D, " cells")
    return int(Nx), int(Nz), float(L)


class PlaneCells(PhiRange):
    """The Nx x Nz cells of the 2-D cell 0 <= x < L (periodic), 0 < z < H, closed by `rheology`
    (with `material`): centres, widths, walls, data of a scene, mass and validity.

    Args:
        rheology, material, V0: as for the 1-D schemes
        N, H, L: the grid (:func:`grid_shape`)
        advection: 'central' (default) or 'upwind'
    """

    name = "fv2d"
    dim = 2

    def __init__(self, rheology: str | Rheology = "icidr", N=None, H: float = 30.0, *, L: float | None = None,
                 material: Material | None = None, V0: float = 1.0, **options):
        self.rheology = get_rheology(rheology, material)
        self.Nx, self.Nz, self.L = grid_shape(N, H, L=L)
        self.H, self.V0 = float(H), float(V0)
        self.option_values = check_options(self.name, options)
        self.advection = self.option_values["advection"]
        self.hx, self.hz = self.L / self.Nx, self.H / self.Nz
        x = (np.arange(self.Nx) + 0.5) * self.hx
        z = (np.arange(self.Nz) + 0.5) * self.hz
        self.xz = np.stack(np.meshgrid(x, z, indexing="ij"), -1)
        self.ghost = np.ascontiguousarray(ghost_coefficients(self.V0))

    @property
    def material(self) -> Material:
        return self.rheology.material

    @property
    def shape(self) -> tuple[int, int]:
        return self.Nx, self.Nz

    def nodes(self, grid=None) -> np.ndarray:
        """Cell centres (Nx, Nz, 2), as py-pde's ``grid.cell_coords``."""
        return self.xz

    def initial_data(self, phi, u, w) -> np.ndarray:
        """(3, Nx, Nz) data from callables of the centres (Nx, Nz, 2) or arrays (or numbers)."""
        return np.array([np.broadcast_to(np.asarray(f(self.xz) if callable(f) else f, float), self.shape)
                         for f in (phi, u, w)], dtype=float)

    def integral(self, values, grid=None) -> float:
        """Midpoint rule over the cell (exact for the mass)."""
        return float(np.sum(values) * self.hx * self.hz)

    def mass(self, data) -> float:
        return self.integral(data[0])

    def pack(self, data) -> np.ndarray:
        """The engines' state vector of (3, Nx, Nz) data (the data flattened)."""
        return np.ascontiguousarray(data, dtype=float).ravel()

    def unpack(self, y) -> np.ndarray:
        """(3, Nx, Nz) data of a state vector."""
        return np.asarray(y).reshape(3, self.Nx, self.Nz)

    def thin(self) -> bool:
        """Whether the py-pde path preconditions this cell along z (hx > THIN_CELL hz)."""
        return thin_cell(self.Nx, self.Nz, self.L, self.H)


#: hx / hz beyond which the Krylov solves are preconditioned along z (:meth:`.pde.ShearCell2DPDE.line_pattern`)
THIN_CELL = 10.0


def thin_cell(Nx: int, Nz: int, L: float, H: float) -> bool:
    """hx > THIN_CELL hz: the cell whose Krylov solves the py-pde path preconditions along z."""
    return L / Nx > THIN_CELL * (H / Nz)


def measures(pde, grid, scene, data) -> dict:
    """max|w|, max|phi - phi0| and sqrt(int (u - z/H)^2 + w^2 dx dz) of one state (3, ...):
    `pde` gives ``nodes(grid)`` and ``integral(values, grid)`` (the py-pde class or :class:`PlaneCells`)."""
    z = pde.nodes(grid)[..., -1]
    phi, u, w = data
    return {"max_w": float(np.max(np.abs(w))),
            "max_phi_dev": float(np.max(np.abs(phi - scene.phi0))),
            "l2_velocity": float(math.sqrt(pde.integral((u - z / scene.H) ** 2 + w**2, grid)))}
