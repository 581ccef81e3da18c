"""One case builder: rheology + scene + discretization + N -> the case to integrate.

:func:`build_case` is the only place where the sequence scene -> scheme -> grid -> state is
written; ``run()``, the native engine, the studies and the benchmarks all start from it. A
1-D case is py-pde-free (the scheme's core, :mod:`icidr_pde.discretizations.core`, and its
initial data); its py-pde PDE, grid and state are made on first use.
"""

from __future__ import annotations

import numpy as np

from .discretizations.registry import get_discretization, get_scheme
from .rheology import Material, get_rheology
from .scenes import Scene, get_scene

__all__ = ["Case", "build_case", "make_pde"]


class Case:
    """A ready-to-integrate case: the scene, the scheme's core on its grid (1-D: ``scheme``,
    ``data``, the initial (3, N) fields) and, made when first asked, the py-pde PDE, grid
    and initial state."""

    def __init__(self, scene: Scene, scheme=None, data=None, *, pde=None, grid=None, state=None):
        self.scene, self.scheme, self.data = scene, scheme, data
        self._pde, self._grid, self._state = pde, grid, state

    @property
    def pde(self):
        """The py-pde class of the scheme (an adapter over :attr:`scheme`)."""
        if self._pde is None:
            s = self.scheme
            self._pde = get_discretization(s.name)(s.rheology, V0=s.V0, **s.option_values)
        return self._pde

    @property
    def grid(self):
        if self._grid is None:
            self._grid = self.pde.make_grid(self.scheme.N, self.scheme.H)
        return self._grid

    @property
    def state(self):
        if self._state is None:
            self._state = self.pde.state_of(self.grid, self.data)
        return self._state

    @property
    def N(self) -> int:
        """Points along z (the 1-D N; Nz of a 2-D grid)."""
        return self.scheme.N if self.scheme is not None else int(self.grid.shape[-1])

    def nodes(self):
        return self.scheme.z.copy() if self.scheme is not None else self.pde.nodes(self.grid)

    def mass(self, data=None) -> float:
        """The scheme's integral of phi over the cell (of the initial state by default)."""
        if self.scheme is not None:
            return self.scheme.mass(self.data if data is None else data)
        return self.pde.integral((self.state.data if data is None else data)[0], self.grid)


def _law(rheology, material):
    law = get_rheology(rheology, material)
    getattr(law, "check_runnable", lambda: None)()   # a CIDR law whose flow rule has no positive p
    return law


def make_pde(rheology="icidr", discretization="fd", material: Material | None = None, **options):
    """The shear-cell PDE for `rheology` discretized by `discretization` (a registry name)."""
    return get_discretization(discretization)(_law(rheology, material), **options)


def build_case(rheology="icidr", scene="shear", discretization="fd", N: int | None = None, *,
               material: Material | None = None, options: dict | None = None,
               scene_params: dict | None = None, check_grid=None) -> Case:
    """Build the case: scene `scene` (with `scene_params`), `rheology` with `material`,
    `discretization` with its `options` on N points (default: the scheme's ``default_N``).
    ``check_grid(pde, grid)``, if given, is called with the py-pde scheme and its grid before the
    state, the first array of the grid's size, is allocated (the run's memory check)."""
    scene_obj = get_scene(scene, **(scene_params or {}))
    entry = get_scheme(discretization) if isinstance(discretization, str) else None
    dim = getattr(scene_obj, "dim", 1)
    if entry is not None and entry.core is not None and dim == entry.dim:
        law = _law(rheology, material)
        law.material.check_phi(scene_obj.phi0, "phi0")
        scheme = entry.core_class()(law, N, scene_obj.H, **(options or {}))
        return Case(scene_obj, scheme, scheme.initial_data(*scene_obj.initial_condition(scheme.z)))
    pde = make_pde(rheology, discretization, material, **(options or {}))
    pde.material.check_phi(scene_obj.phi0, "phi0")
    dims = dim, getattr(pde, "dim", 1)
    if dims[0] != dims[1]:
        raise ValueError(f"scene {scene_obj.name!r} is {dims[0]}-D but discretization {pde.name!r} is "
                         f"{dims[1]}-D; choose a {dims[0]}-D discretization")
    grid_options = scene_obj.grid_options() if hasattr(scene_obj, "grid_options") else {}
    grid = pde.make_grid(type(pde).default_N if N is None else N, scene_obj.H, **grid_options)
    if check_grid is not None:
        check_grid(pde, grid)
    state = pde.make_state(grid, *scene_obj.initial_condition(pde.nodes(grid)))
    return Case(scene_obj, pde=pde, grid=grid, state=state)
