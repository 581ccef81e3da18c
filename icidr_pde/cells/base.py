"""The descriptor of a cell and the registry :data:`CELLS` its subclasses fill.

A cell is a domain with its walls, the fields on it and the schemes that discretize it: one
package of :mod:`icidr_pde.cells`. Its descriptor, a subclass of :class:`Cell` with a ``name``
in the package's ``cell.py``, registers itself in :data:`CELLS` (as a scene does in
:data:`icidr_pde.scene_base.SCENES`) and is what the rest of the package asks instead of
testing a dimension: which schemes and scenes are the cell's, the kinematics of its laws, its
compiled templates and compiled problem, the Jacobian structure of each scheme, what the
native engine runs it with, how its grid is named and what its Result adds.

Importing this module imports nothing but the standard library: the run path asks a cell
before it has decided to load py-pde, numba or scipy.
"""

from __future__ import annotations

import importlib
import pathlib
from dataclasses import dataclass, field

__all__ = ["Cell", "CELLS", "Template"]

#: name -> the cell's descriptor (one instance); filled by the subclasses themselves
CELLS: dict[str, "Cell"] = {}


@dataclass(frozen=True)
class Template:
    """A numba template of a scheme (`path`, relative to the cell's folder), printed as C by
    :func:`icidr_pde.native.translate.translate` with the prefix `prefix`, the array macros
    `macros` (an array name -> the C macro that indexes it) and, if given, only the functions
    `names`."""

    path: str
    prefix: str
    macros: dict = field(default_factory=dict)
    names: tuple | None = None


def _load(path: str):
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


class Cell:
    """One cell (see the module docstring). A subclass sets the class attributes below and
    the methods whose answers depend on the cell's grid."""

    #: the registry key (the package's name)
    name = ""
    #: the number of space dimensions of its grid
    dim = 1
    #: the name of the kinematics its laws are evaluated in (icidr_pde.rheology.kinematics: 'shear_cell', ...)
    kinematics = ""
    #: its schemes: names in :data:`icidr_pde.discretizations.registry.SCHEMES`
    schemes: tuple[str, ...] = ()
    #: its scenes: names in :data:`icidr_pde.scene_base.SCENES` (their module: :attr:`scenes_module`)
    scenes: tuple[str, ...] = ()
    scenes_module = ""
    #: what its Result holds beyond the fields every run has (the Result's attribute names)
    result_fields: tuple[str, ...] = ()
    #: the names of its grid's sizes, as the parameters say them (('N',), ('Nx', 'Nz'))
    grid_axes: tuple[str, ...] = ("N",)
    #: scheme -> its Jacobian structure: the flags of :class:`icidr_pde.engines.choose.JacobianStructure`
    jacobian: dict = {}
    #: scheme -> (Jacobian mode, linear solver kind[, preconditioner]) of the native engine on it, the kind and
    #: preconditioner as :func:`icidr_pde.engines.linear.compiled_solver` takes them (schemes it has no C problem
    #: of: absent)
    native: dict = {}
    #: scheme -> "module:function" building its compiled problem from the run path's case on the scheme's core
    native_problems: dict = {}
    #: scheme -> "module:Class" of the py-pde-free core its compiled problem is built on, where the
    #: scheme registry names none (the 2-D scheme's py-pde class builds its own grid)
    native_cores: dict = {}
    #: the templates of its compiled library, in the order the library prints them
    templates: tuple[Template, ...] = ()
    #: C definitions its library needs before the law (the law printer's inline and scratch macros)
    c_defines = ""
    #: its compiled problems' C file in its folder (:file:`icidr_pde/native/problem.h` says what a problem is)
    compiled_problem = "problem.c"
    #: the functions its C file exports beyond the driver's, name -> "restype: argument types" in the
    #: letters of :func:`icidr_pde.native.build.c_types` (P pointer, D double, I int, L long, S char *,
    #: *D a pointer to doubles, ...; restype '-': none)
    c_functions: dict = {}
    #: whether the run's live figure and movie can draw its fields (profiles against z)
    profiles = True

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            CELLS[cls.name] = cls()

    @classmethod
    def registered(cls) -> "Cell":
        """The descriptor of this cell in :data:`CELLS`."""
        return CELLS[cls.name]

    def __repr__(self) -> str:
        return f"<cell {self.name}: {self.dim}-D, schemes {', '.join(self.schemes)}>"

    @property
    def package(self) -> str:
        return f"icidr_pde.cells.{self.name}"

    @property
    def folder(self) -> pathlib.Path:
        return pathlib.Path(__file__).parent / self.name

    def template_texts(self) -> tuple[str, ...]:
        """The sources of :attr:`templates` (read by path: no scheme module is imported)."""
        return tuple((self.folder / t.path).read_text() for t in self.templates)

    def problem_source(self) -> str:
        """The C of its compiled problems (:attr:`compiled_problem`)."""
        return (self.folder / self.compiled_problem).read_text()

    def native_problem(self, scheme: str):
        """The function building the compiled problem of `scheme` from a case (imported now)."""
        try:
            return _load(self.native_problems[scheme])
        except KeyError:
            raise ValueError(f"the native engine has no problem of discretization {scheme!r} "
                             f"(cell {self.name}: {sorted(self.native_problems)})") from None

    def native_core(self, scheme: str):
        """The core class of `scheme` named by this cell (None: the scheme registry's)."""
        return _load(self.native_cores[scheme]) if scheme in self.native_cores else None

    # --- what depends on the grid ---------------------------------------------------------------

    def make_grid(self, pde, core):
        """The py-pde grid of the scheme core `core` (its py-pde class: `pde`)."""
        return pde.make_grid(core.N, core.H)

    def make_state(self, pde, grid, data):
        """The py-pde state of the fields `data` (3, ...) on `grid`."""
        return pde.state_of(grid, data)

    def points_along_z(self, core) -> int:
        """The points along z of the scheme core `core` (the Result's ``N``)."""
        return int(core.N)

    def owns_grid(self, N) -> bool:
        """Whether a grid size `N` as given can only be this cell's (a pair (Nx, Nz): the 2-D cell's)."""
        return False

    def grid_words(self, shape) -> str:
        """The grid of `shape` as a message names it: "`N` = 201", "`Nx` x `Nz` = 64 x 32"."""
        names = " x ".join(f"`{a}`" for a in self.grid_axes)
        return f"{names} = " + " x ".join(str(int(n)) for n in shape)

    def choice_grid(self, scene, N, scene_params=None) -> dict:
        """What :func:`icidr_pde.engines.choose.choose` is told of the grid of `scene` with `N`
        (keywords `cells`, `thin_cell`); nothing where the cell has nothing to tell or the scene
        or N is invalid (the case builder says why)."""
        return {}

    def native_refusal(self, thin_cell: bool = False, cells: int | None = None) -> str:
        """Why the native engine does not take this grid (one line), or ''; `cells` None: any grid."""
        return ""

    def result_extras(self, case, data) -> dict:
        """The Result's fields of :attr:`result_fields` for the snapshots `data` of `case`."""
        return {}

    def result_summary(self, result) -> dict:
        """What :meth:`icidr_pde.result.Result.to_dict` adds for a run of this cell."""
        return {}
