"""The look-up of a law: a registered name (:data:`~.registry.RHEOLOGIES`, filled by the law classes
themselves), a law file (:mod:`.law_files`), or a Rheology as it is."""

from __future__ import annotations

from .base import Rheology
from .law_files import is_file_law, load_law_file
from .material import Material
from .registry import RHEOLOGIES

__all__ = ["get_rheology"]


def get_rheology(name, material: Material | None = None) -> Rheology:
    """The rheology registered as `name` (see :data:`RHEOLOGIES`), a law file ``*.toml`` or
    ``*.py`` (:func:`~.law_files.load_law_file`: a ``*.py`` file is run, it is a
    program), or `name` if it is a Rheology."""
    if isinstance(name, Rheology):
        return name
    if is_file_law(name):   # a law written in a file (rheology workbench)
        return load_law_file(name)(material)
    try:
        cls = RHEOLOGIES[name]
    except (KeyError, TypeError):
        raise ValueError(f"`rheology` must be one of {sorted(RHEOLOGIES)}; got {name!r}") from None
    return cls(material)
