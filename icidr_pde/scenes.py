"""Scenes: what geometry, initial condition and outputs a study of a cell needs.

A scene is a cell with an initial condition; nothing else is modelled. A subclass of
:class:`~icidr_pde.scene_base.Scene` with a ``name`` registers itself in :data:`SCENES`; its
dataclass fields are its parameters (the CLI offers one flag per parameter, help from the
field's ``metadata``). Each cell's scenes are in its folder (its descriptor names the module:
the paper's ``shear`` (3.16) and ``sine`` (5.7) in :mod:`icidr_pde.cells.shear1d.scenes`, the
2-D bumps and modes in :mod:`icidr_pde.cells.plane2d.scenes`); importing this module
registers every cell's.
"""

from __future__ import annotations

from dataclasses import fields

from .cells import load_scenes
from .cells.shear1d.scenes import ShearScene, SineScene
from .scene_base import _NOT_PARAMETERS, SCENES, Scene

__all__ = ["Scene", "ShearScene", "SineScene", "SCENES", "get_scene", "scene_parameters"]


def scene_parameters() -> dict[str, str]:
    """Every parameter of every registered scene -> its help text (for the command line)."""
    out = {}
    for cls in SCENES.values():
        for f in fields(cls):
            if f.name not in _NOT_PARAMETERS:
                out.setdefault(f.name, f.metadata.get("help", f.name))
    return out


def get_scene(name: str | Scene, **params) -> Scene:
    """Scene `name` (a key of :data:`SCENES`) with any parameter overridden by keyword."""
    if isinstance(name, Scene):
        return name
    try:
        cls = SCENES[name]
    except KeyError:
        raise ValueError(f"`scene` must be one of {sorted(SCENES)}; got {name!r}") from None
    known = {f for f in cls.__dataclass_fields__ if f not in _NOT_PARAMETERS}
    unknown = set(params) - known
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)} for scene {name!r}; "
                         f"valid: {sorted(known)}")
    return cls(**params)


# every cell's scenes in the registry's order, the 1-D cell's first (scene_parameters takes the first help text)
load_scenes()
