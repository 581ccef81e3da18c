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
from .validation import invalid_state

__all__ = ["Case", "build_case", "make_pde"]


class Case:
    """A ready-to-integrate case: the scene, the scheme's py-pde-free core on its grid
    (``scheme``, ``data``, the initial fields) or, made when first asked, the py-pde PDE, grid
    and initial state. What every engine asks of a case is here, once: the fields of a state
    vector, the mass, the validity of a state (non-finite, phi outside its range), the nodes."""

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
            self._grid = self.cell.make_grid(self.pde, self.scheme)
        return self._grid

    @property
    def state(self):
        if self._state is None and self.scheme is None:  # the py-pde class's, of the scene
            self._state = self.pde.make_state(self.grid, *self.scene.initial_condition(self.pde.nodes(self.grid)))
        elif self._state is None:
            self._state = self.cell.make_state(self.pde, self.grid, self.data)
        return self._state

    def initial_block(self, block) -> np.ndarray:
        """The initial fields (3, mx, mz) of the cells xs:xe, zs:ze of a 2-D grid, block = ((xs,
        xe), (zs, ze)) (a rank's block of a distributed grid): the initial state's values there,
        computed on the block alone where the whole state was not made."""
        (xs, xe), (zs, ze) = block
        if self._state is not None or self.scheme is not None:
            return np.array(self.initial[:, xs:xe, zs:ze])
        nodes = self.pde.nodes(self.grid, block)
        return np.array([np.broadcast_to(np.asarray(f, float), nodes.shape[:-1])
                         for f in self.scene.initial_condition(nodes)])

    @property
    def rheology(self):
        return self.scheme.rheology if self.scheme is not None else self.pde.rheology

    @property
    def discretization(self) -> str:
        """The scheme's registry name."""
        return self.scheme.name if self.scheme is not None else self.pde.name

    @property
    def options(self) -> dict:
        """The scheme's options (advection, ...) with their values."""
        return dict(self.scheme.option_values) if self.scheme is not None else self.pde.option_values()

    @property
    def H(self) -> float:
        return self.scheme.H if self.scheme is not None else float(self.scene.H)

    @property
    def V0(self) -> float:
        return self.scheme.V0

    @property
    def advection(self) -> str | None:
        return self.options.get("advection")

    @property
    def initial(self) -> np.ndarray:
        """The initial fields (3, ...)."""
        return self.data if self.scheme is not None else self.state.data

    @property
    def z(self):
        """Positions of the unknowns."""
        return self.nodes()

    def nodes(self):
        return self.scheme.nodes() if self.scheme is not None else self.pde.nodes(self.grid)

    @property
    def y0(self) -> np.ndarray:
        """The initial state vector of an engine that integrates the core's layout (:meth:`fields`)."""
        return self.scheme.pack(self.data)

    def fields(self, y) -> np.ndarray:
        """The fields (3, ...) of a state vector in the core's layout."""
        return self.scheme.unpack(y)

    def phi(self, y) -> np.ndarray:
        return self.fields(y)[0]

    def mass(self, data=None) -> float:
        """The scheme's integral of phi over the cell (of the initial state by default)."""
        if self.scheme is not None:
            return self.scheme.mass(self.data if data is None else data)
        return self.pde.integral((self.state.data if data is None else data)[0], self.grid)

    def check_state(self, y) -> str | None:
        """Why the state vector `y` (the core's layout) is invalid, or None."""
        return invalid_state(y, self.scheme.check_state, self.fields)

    def strain_rates(self, data):
        """Where the stresses live and (phi, u_z, w_z) there."""
        return self.scheme.strain_rates(data) if self.scheme is not None else self.pde.strain_rates(data, self.grid)

    # --- what the 2-D cell adds (its grid along x and measures); nothing on the 1-D cells -------

    @property
    def N(self) -> int:
        """Points along z (the 1-D N; Nz of a 2-D grid)."""
        if self.scheme is None:
            return int(self.grid.shape[-1])
        return self.cell.points_along_z(self.scheme)

    @property
    def dim(self) -> int:
        return self.cell.dim

    @property
    def cell(self):
        """The descriptor of the case's cell (:mod:`icidr_pde.cells`), of its scheme."""
        from .cells import cell_of

        return cell_of(self.scheme if self.scheme is not None else self.pde)

    def plane(self, data) -> dict:
        """What the cell's Result adds for the snapshots `data` (the 2-D cell: its grid along x and
        per-snapshot measures; the 1-D cell: nothing): the cell's :meth:`~icidr_pde.cells.base.Cell.result_extras`."""
        return self.cell.result_extras(self, data)


def _law(rheology, material):
    law = get_rheology(rheology, material)
    getattr(law, "check_runnable", lambda: None)()   # a CIDR law whose flow rule has no positive p
    return law


def make_pde(rheology="icidr", discretization="fd", material: Material | None = None, **options):
    """The shear-cell PDE for `rheology` discretized by `discretization` (a registry name)."""
    return get_discretization(discretization)(_law(rheology, material), **options)


def build_case(rheology="icidr", scene="shear", discretization="fd", N: int | None = None, *,
               material: Material | None = None, options: dict | None = None,
               scene_params: dict | None = None, check_grid=None, core=None) -> Case:
    """Build the case: scene `scene` (with `scene_params`), `rheology` with `material`,
    `discretization` with its `options` on N points (default: the scheme's ``default_N``), on the
    scheme's py-pde-free core (`core`, else the registry's), else on its py-pde class.
    ``check_grid(pde, grid)``, if given, is called with the py-pde scheme and its grid before the
    state, the first array of the grid's size, is allocated (the run's memory check); the py-pde
    class's state is made where first asked (:attr:`Case.state`; a distributed run's rank makes
    only its block, :meth:`Case.initial_block`)."""
    scene_obj = get_scene(scene, **(scene_params or {}))
    entry = get_scheme(discretization) if isinstance(discretization, str) else None
    dim = getattr(scene_obj, "dim", 1)
    if core is None and entry is not None and entry.core is not None and dim == entry.dim:
        core = entry.core_class()
    if core is not None:
        if getattr(core, "dim", 1) != dim:
            raise ValueError(f"scene {scene_obj.name!r} is {dim}-D but discretization {core.name!r} is "
                             f"{getattr(core, 'dim', 1)}-D; choose a {dim}-D discretization")
        law = _law(rheology, material)
        law.material.check_phi(scene_obj.phi0, "phi0")
        grid_options = scene_obj.grid_options() if hasattr(scene_obj, "grid_options") else {}
        scheme = core(law, N, scene_obj.H, **grid_options, **(options or {}))
        return Case(scene_obj, scheme, scheme.initial_data(*scene_obj.initial_condition(scheme.nodes())))
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
    return Case(scene_obj, pde=pde, grid=grid)  # its state made where first asked (a rank's block: never)
