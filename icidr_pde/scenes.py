"""Scenes: what geometry, initial condition and outputs a study of the shear cell needs.

A scene is the 1-D cell 0 < z < H (3.9) with an initial condition; nothing else is
modelled. A subclass with a ``name`` registers itself in :data:`SCENES`; its dataclass
fields are its parameters (the CLI offers one flag per parameter, help from the field's
``metadata``). The two scenes of the paper:

* ``shear``: steady linear shear plus a small smooth w bump, (3.16):
  phi = phi0, u = z/H, w = eps (z - H/2) exp(-(z - H/2)^2);
* ``sine``: a large perturbation with u_z = 0 somewhere, (5.7):
  phi = phi0, u = z/H + a sin(2 pi z/H), w = -b sin(2 pi z/H).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .scene_base import _NOT_PARAMETERS, SCENES, Scene
from .validation import real

__all__ = ["Scene", "ShearScene", "SineScene", "SCENES", "get_scene", "scene_parameters"]


@dataclass(frozen=True)
class ShearScene(Scene):
    """Initial condition (3.16): steady shear with a Gaussian-derivative w bump of size `eps`."""

    name = "shear"
    eps: float = field(default=0.05, metadata={"help": "amplitude of the w bump of (3.16)"})
    outputs: tuple = field(default=("max_w", "snapshots", "chi"), compare=False)

    def __post_init__(self):
        super().__post_init__()
        real("eps", self.eps)

    def initial_condition(self, z):
        zc = z - self.H / 2
        return (np.full_like(z, self.phi0), z / self.H, self.eps * zc * np.exp(-zc**2))


@dataclass(frozen=True)
class SineScene(Scene):
    """Initial condition (5.7): sinusoidal u and w perturbations of amplitudes `a`, `b`."""

    name = "sine"
    a: float = field(default=0.16, metadata={"help": "u amplitude of (5.7)"})
    b: float = field(default=0.1, metadata={"help": "w amplitude of (5.7)"})
    outputs: tuple = field(default=("max_w", "snapshots", "chi"), compare=False)
    default_times: tuple = field(default=(0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0), compare=False)

    def __post_init__(self):
        super().__post_init__()
        for name in ("a", "b"):
            real(name, getattr(self, name))

    def initial_condition(self, z):
        s = np.sin(2 * np.pi * z / self.H)
        return (np.full_like(z, self.phi0), z / self.H + self.a * s, -self.b * s)


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


# after the 1-D scenes: SCENES keeps their order first (scene_parameters takes the first help text)
from .cells.plane2d import scenes as scenes2d  # noqa: E402,F401  (registers the scenes of the 2-D cell)
