"""Scenes of the 2-D x-periodic shear cell 0 <= x < L, 0 < z < H (discretization ``fv2d``).

* ``bump2d``: steady shear phi = phi0, u = z/H plus a localised w bump,
  w(x, z, 0) = eps ((z - H/2)/ell) exp(-((x - L/2)^2 + (z - H/2)^2)/ell^2),
  eps = 0.05, ell = 3, L = H = 30 (the 2-D analogue of (3.16));
* ``mode2d``: steady shear plus a small plane wave of wavenumber k at angle theta
  (n = (cos theta, sin theta), theta = 90 deg is the 1-D direction z): the velocity
  perturbation eps (cos alpha, sin alpha) sin(k n.x) sin(pi z/H), the last factor keeping
  the walls exact; k n_x is rounded to a multiple of 2 pi/L so that the wave is periodic.
  It measures the growth of single oblique modes against Lambda_max(theta);
* ``bump1d``: the 1-D cell with bump2d's perturbation made x-independent,
  w = eps ((z - H/2)/ell) exp(-(z - H/2)^2/ell^2).

Initial conditions are functions of the node positions ``xz`` (shape (..., 2)).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...scene_base import Scene
from ...validation import real

__all__ = ["Scene2D", "Bump2DScene", "Bump1DScene", "Mode2DScene"]


#: widths of the bump whose square is a normal float number (ell = 1e308 overflowed ell^2)
WIDTH_RANGE = (1e-100, 1e100)


def check_width(ell) -> float:
    """The bump width `ell`, a number in :data:`WIDTH_RANGE`."""
    return real("ell", ell, *WIDTH_RANGE, low_open=False, high_open=False)


@dataclass(frozen=True)
class Scene2D(Scene):
    """A scene of the 2-D cell: adds the period `L` of the x axis."""

    L: float = field(default=30.0, metadata={"help": "cell length (period in x), 2-D scenes"})
    discretization = "fv2d"
    dim = 2

    def __post_init__(self):
        super().__post_init__()
        if not (np.isfinite(self.L) and self.L > 0):
            raise ValueError(f"`L` must be > 0; got {self.L}")

    def grid_options(self) -> dict:
        """Keyword arguments of the discretization's ``make_grid`` beyond N and H."""
        return {"L": self.L}

    def steady_shear(self, xz):
        z = xz[..., 1]
        return np.full(z.shape, self.phi0), z / self.H, np.zeros(z.shape)


@dataclass(frozen=True)
class Bump2DScene(Scene2D):
    """Steady shear plus the localised w bump eps ((z - H/2)/ell) exp(-r^2/ell^2)."""

    name = "bump2d"
    eps: float = field(default=0.05, metadata={"help": "amplitude of the w bump (bump2d)"})
    ell: float = field(default=3.0, metadata={"help": "width of the w bump (bump2d)"})

    def __post_init__(self):
        super().__post_init__()
        if not np.isfinite(self.eps):
            raise ValueError(f"`eps` must be finite; got {self.eps}")
        check_width(self.ell)

    def initial_condition(self, xz):
        phi, u, _ = self.steady_shear(xz)
        x, z = xz[..., 0], xz[..., 1]
        zc, xc = z - self.H / 2, x - self.L / 2
        w = self.eps * (zc / self.ell) * np.exp(-(xc**2 + zc**2) / self.ell**2)
        return phi, u, w

    def x_independent(self) -> "Bump1DScene":
        """The same perturbation without its x-dependence, as a scene of the 1-D cell."""
        return Bump1DScene(H=self.H, phi0=self.phi0, eps=self.eps, ell=self.ell)


@dataclass(frozen=True)
class Bump1DScene(Scene):
    """The x-independent companion of bump2d in the 1-D cell: w = eps ((z - H/2)/ell) exp(-(z - H/2)^2/ell^2)."""

    name = "bump1d"
    eps: float = field(default=0.05, metadata={"help": "amplitude of the w bump (bump2d)"})
    ell: float = field(default=3.0, metadata={"help": "width of the w bump (bump2d)"})

    def __post_init__(self):
        super().__post_init__()
        check_width(self.ell)

    def initial_condition(self, z):
        zc = z - self.H / 2
        return np.full_like(z, self.phi0), z / self.H, self.eps * (zc / self.ell) * np.exp(-zc**2 / self.ell**2)


@dataclass(frozen=True)
class Mode2DScene(Scene2D):
    """Steady shear plus eps (cos alpha, sin alpha) sin(k n.x) sin(pi z/H), n at angle theta."""

    name = "mode2d"
    eps: float = field(default=1e-4, metadata={"help": "amplitude of the plane wave (mode2d)"})
    k: float = field(default=2.0, metadata={"help": "wavenumber of the plane wave (mode2d)"})
    theta: float = field(default=45.0, metadata={"help": "angle of the wave vector from x, degrees (mode2d)"})
    alpha: float = field(default=45.0, metadata={"help": "angle of the velocity perturbation from x, degrees (mode2d)"})

    def __post_init__(self):
        super().__post_init__()
        for name in ("eps", "theta", "alpha"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"`{name}` must be finite; got {getattr(self, name)}")
        if not (np.isfinite(self.k) and self.k > 0):
            raise ValueError(f"`k` must be > 0; got {self.k}")

    def wave_vector(self) -> tuple[float, float]:
        """(k_x, k_z): k n with k_x rounded to the nearest multiple of 2 pi/L."""
        t = np.radians(self.theta)
        kx = 2 * np.pi / self.L * np.round(self.k * np.cos(t) * self.L / (2 * np.pi))
        return float(kx), float(self.k * np.sin(t))

    def initial_condition(self, xz):
        phi, u, w = self.steady_shear(xz)
        x, z = xz[..., 0], xz[..., 1]
        kx, kz = self.wave_vector()
        wave = self.eps * np.sin(kx * x + kz * z) * np.sin(np.pi * z / self.H)
        a = np.radians(self.alpha)
        return phi, u + np.cos(a) * wave, w + np.sin(a) * wave

