"""The scenes of the 1-D shear cell 0 < z < H (3.9), the two of the paper:

* ``shear``: steady linear shear plus a small smooth w bump, (3.16):
  phi = phi0, u = z/H, w = eps (z - H/2) exp(-(z - H/2)^2);
* ``sine``: a large perturbation with u_z = 0 somewhere, (5.7):
  phi = phi0, u = z/H + a sin(2 pi z/H), w = -b sin(2 pi z/H).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...scene_base import Scene
from ...validation import real

__all__ = ["ShearScene", "SineScene"]


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
