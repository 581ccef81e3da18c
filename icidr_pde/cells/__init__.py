"""The cells, each one package: ``shear1d`` (the 1-D shear cell 0 < z < H, schemes ``fd`` and
``cheb``) and ``plane2d`` (the x-periodic 2-D cell, finite volumes ``fv2d``).

A cell's package holds its py-pde-free cores, templates, py-pde adapters, scenes and the
bindings of its compiled problems; its ``cell.py`` holds its descriptor (:class:`.base.Cell`),
which registers itself in :data:`CELLS`. :data:`PACKAGES` is the registry's one row a cell: the
descriptors load on the first look-up. What the rest of the package asks of a cell it asks
through :func:`get_cell` and :func:`cell_of`, never by testing a dimension.
"""

from __future__ import annotations

import importlib

from .base import CELLS, Cell, Template

__all__ = ["Cell", "CELLS", "Template", "PACKAGES", "cells", "get_cell", "cell_of", "cell_for", "cell_of_result",
           "load_scenes", "choice_asks"]

#: the cells' packages, one row a cell (the descriptor is the package's ``cell.py``)
PACKAGES = ("shear1d", "plane2d")


def cells() -> dict[str, Cell]:
    """name -> descriptor of every cell in the registry's order, whichever was imported first
    (their ``cell.py`` imported on the first call)."""
    for package in PACKAGES:
        if package not in CELLS:
            importlib.import_module(f"{__name__}.{package}.cell")
    return {**{package: CELLS[package] for package in PACKAGES}, **CELLS}


def get_cell(name: str) -> Cell:
    """The cell `name`."""
    try:
        return cells()[name]
    except (KeyError, TypeError):
        raise ValueError(f"`cell` must be one of {sorted(cells())}; got {name!r}") from None


def cell_of(what, *, default=...) -> Cell:
    """The cell of `what`: a scheme (its registry name or an object with a ``name``, as a py-pde
    class or a scheme core), a kinematics (an object whose ``name`` is a cell's kinematics) or a
    scene (a name, class or instance); an object the registry does not know by name belongs to
    the cell of its ``dim`` (1 by default). `default`, if given, is returned for a name no cell has."""
    name = what if isinstance(what, str) else getattr(what, "name", None)
    for cell in cells().values():
        if name in cell.schemes or name in cell.scenes or (name and name == cell.kinematics):
            return cell
    if isinstance(what, str) or what is None:
        if default is not ...:
            return default
        raise ValueError(f"no cell has a scheme, scene or kinematics named {what!r}")
    return _of_dim(getattr(what, "dim", 1))


def cell_for(scene=None, N=None) -> Cell:
    """The cell a run of `scene` (a name, a class, an instance or None) on the grid size `N` lies
    on: the cell that `N` can only be a grid of (a pair (Nx, Nz)), else the scene's (a scene the
    registry does not know: the 1-D cell)."""
    for cell in cells().values():
        if cell.owns_grid(N):
            return cell
    if isinstance(scene, str):
        from ..scene_base import SCENES

        load_scenes()
        scene = SCENES.get(scene)
    return cell_of(scene) if scene is not None else _of_dim(1)


def choice_asks(scheme: str, grid_cell: Cell | None = None, request: str = "auto", **grid) -> dict:
    """What :func:`icidr_pde.engines.choose.choose` is told by the cells of a run of `scheme` (its
    registry name) on a grid of `grid_cell` (default: the scheme's cell) described by `grid` (the
    keywords of :meth:`~.base.Cell.choice_grid`), with the engine `request`: the scheme's Jacobian
    structure and native engine (:attr:`~.base.Cell.jacobian`, :attr:`~.base.Cell.native`), the
    schemes the native engine has and every scheme's structure (what refusals name), and why
    the native engine does not take the grid (a grid of another cell, or
    :meth:`~.base.Cell.native_refusal`; on 'auto' the grid's size counts), as plain values (an
    engine imports no cell)."""
    own = cell_of(scheme, default=None) if isinstance(scheme, str) else None
    on = grid_cell or own
    refusal = ""
    if own is not None and on is not own:
        refusal = f"a {on.dim}-D grid for discretization {scheme!r}"
    elif own is not None:
        refusal = own.native_refusal(grid.get("thin_cell", False), grid.get("cells") if request == "auto" else None)
    registered = cells().values()
    return dict(discretization=scheme, structure=dict(own.jacobian.get(scheme, {})) if own else {},
                native=own.native.get(scheme) if own else None, native_refusal=refusal,
                native_schemes=tuple(s for cell in registered for s in cell.native),
                schemes={s: dict(flags) for cell in registered for s, flags in cell.jacobian.items()}, **grid)


def load_scenes() -> None:
    """Register every cell's scenes (its descriptor's ``scenes_module``), in the registry's order."""
    for cell in cells().values():
        importlib.import_module(cell.scenes_module)


def cell_of_result(result) -> Cell:
    """The cell of a Result: its scheme's; a scheme the registry does not know (a py-pde class
    given as the discretization): the cell whose :attr:`~.base.Cell.result_fields` it holds, the
    one with the most of them."""
    named = cell_of(result.discretization, default=None)
    if named is not None:
        return named
    held = [cell for cell in cells().values()
            if all(getattr(result, name, None) is not None for name in cell.result_fields)]
    return max(held, key=lambda cell: len(cell.result_fields))


def _of_dim(dim: int) -> Cell:
    """The cell of an object the registry does not know by name: the one of its dimension."""
    found = [cell for cell in cells().values() if cell.dim == dim]
    if len(found) != 1:
        raise ValueError(f"no single cell is {dim}-D: name the scheme or scene")
    return found[0]
