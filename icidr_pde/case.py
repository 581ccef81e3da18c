"""One case builder: rheology + scene + discretization + N -> (PDE, grid, initial state).

:func:`build_case` is the only place where the sequence scene -> PDE -> grid -> state is
written; ``run()``, the studies and the benchmarks all start from it.
"""

from __future__ import annotations

from dataclasses import dataclass

from pde import CartesianGrid, FieldCollection

from .discretizations import ShearCellBase, get_discretization
from .rheology import Material, get_rheology
from .scenes import Scene, get_scene

__all__ = ["Case", "build_case", "make_pde"]


@dataclass
class Case:
    """A ready-to-integrate case: the discretized PDE, its grid, the initial state, the scene."""

    pde: ShearCellBase
    grid: CartesianGrid
    state: FieldCollection
    scene: Scene

    @property
    def N(self) -> int:
        """Points along z (the 1-D N; Nz of a 2-D grid)."""
        return int(self.grid.shape[-1])

    def nodes(self):
        return self.pde.nodes(self.grid)

    def mass(self, data=None) -> float:
        """The scheme's integral of phi over the cell (of the initial state by default)."""
        return self.pde.integral((self.state.data if data is None else data)[0], self.grid)


def make_pde(rheology="icidr", discretization="fd", material: Material | None = None, **options):
    """The shear-cell PDE for `rheology` discretized by `discretization` (a registry name)."""
    law = get_rheology(rheology, material)
    getattr(law, "check_runnable", lambda: None)()   # a CIDR law whose flow rule has no positive p
    return get_discretization(discretization)(law, **options)


def build_case(rheology="icidr", scene="shear", discretization="fd", N: int | None = None, *,
               material: Material | None = None, options: dict | None = None,
               scene_params: dict | None = None) -> Case:
    """Build the case: scene `scene` (with `scene_params`), `rheology` with `material`,
    `discretization` with its `options` on N points (default: the scheme's ``default_N``)."""
    scene_obj = get_scene(scene, **(scene_params or {}))
    pde = make_pde(rheology, discretization, material, **(options or {}))
    pde.material.check_phi(scene_obj.phi0, "phi0")
    dims = getattr(scene_obj, "dim", 1), getattr(pde, "dim", 1)
    if dims[0] != dims[1]:
        raise ValueError(f"scene {scene_obj.name!r} is {dims[0]}-D but discretization {pde.name!r} is "
                         f"{dims[1]}-D; choose a {dims[0]}-D discretization")
    grid_options = scene_obj.grid_options() if hasattr(scene_obj, "grid_options") else {}
    grid = pde.make_grid(type(pde).default_N if N is None else N, scene_obj.H, **grid_options)
    state = pde.make_state(grid, *scene_obj.initial_condition(pde.nodes(grid)))
    return Case(pde, grid, state, scene_obj)
