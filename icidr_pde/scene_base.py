"""The base of every scene and the registry :data:`SCENES` its named subclasses fill.

A subclass with a ``name`` registers itself in :data:`SCENES`; its dataclass fields are
its parameters. The scenes themselves live in :mod:`icidr_pde.cells.shear1d.scenes` (the 1-D
cell, (3.16) and (5.7)) and :mod:`icidr_pde.cells.plane2d.scenes` (the 2-D cell), registered by
:mod:`icidr_pde.scenes`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from .validation import real

__all__ = ["Scene", "SCENES"]

#: name -> Scene subclass; filled by the subclasses themselves
SCENES: dict[str, type] = {}
_NOT_PARAMETERS = ("outputs", "default_times")


@dataclass(frozen=True)
class Scene:
    """Base scene: cell height `H`, mean packing fraction `phi0`, requested outputs."""

    name = ""
    H: float = field(default=30.0, metadata={"help": "cell height"})
    phi0: float = field(default=0.78, metadata={"help": "mean packing fraction"})
    outputs: tuple = field(default=("max_w", "snapshots"), compare=False)
    default_times: tuple = field(default=(0.0, 0.5, 1.0, 2.0, 5.0, 10.0), compare=False)

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            SCENES[cls.name] = cls

    def __post_init__(self):
        real("H", self.H, 0)
        real("phi0", self.phi0, 0, 1, what="a finite number (below phi_c)")

    def initial_condition(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError

    def parameters(self) -> dict:
        return {k: v for k, v in asdict(self).items() if k not in _NOT_PARAMETERS}
