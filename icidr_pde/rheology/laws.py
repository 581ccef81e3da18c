"""Friction laws mu(I) and dilatancy laws Phi(I), Psi(phi): the pluggable parts of a Material.

A law is a frozen dataclass whose fields are its parameters (validated on construction,
each error naming the parameter, its valid range and the value received) and whose
sympy methods are its definition; numeric versions are generated from them
(:mod:`icidr_pde.rheology.codegen`). A new law is one small subclass; it registers
itself under its ``name`` in :data:`FRICTION_LAWS` or :data:`DILATANCY_LAWS`.

* :class:`MuOfI` -- (2.10) mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1), Table 1 defaults;
* :class:`LinearDilatancy` -- (2.11) Phi(I) = phi_c - a I, Psi(phi) = (phi_c - phi)/a (2.13);
* :class:`SaturatingDilatancy` -- the alternative of section 2,
  Phi(I) = phi_c - (phi_c - phi_min)/(I_*/I + 1), which stays above phi_min for every I.
  Inverting it (a test checks Psi(Phi(I)) = I symbolically) gives
  Psi(phi) = I_* (phi_c - phi)/(phi - phi_min) on phi_min < phi < phi_c.
  The paper gives no values; the defaults are I_* = 1 (the end of the dense inertial
  regime, where I ~ 1 marks the transition to collisional flow, GDR MiDi 2004) and
  phi_min = phi_c - a I_* = 0.503 with Table 1's phi_c and a, so that
  dPhi/dI = -(phi_c - phi_min)/I_* = -a at I = 0: the law is tangent to (2.11) at small I
  (at phi = 0.78 the two give I = 0.118 and 0.132).

Symbolic methods take the parameter values as a mapping ``prm`` (numbers or sympy
symbols, see :meth:`Law.values`), so one definition serves both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import ClassVar

import numpy as np

__all__ = ["Law", "FrictionLaw", "DilatancyLaw", "MuOfI", "LinearDilatancy", "SaturatingDilatancy",
           "FRICTION_LAWS", "DILATANCY_LAWS", "TABLE1"]

#: the paper's Table 1 (2-D polydisperse disks)
TABLE1 = {"mu_s": 0.248, "mu_d": 0.588, "I0": 0.145, "phi_c": 0.817, "a": 0.314}

FRICTION_LAWS: dict[str, type] = {}
DILATANCY_LAWS: dict[str, type] = {}


def _check_finite(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise ValueError(f"Material parameter `{name}` must be a finite number, got {value!r}")


@dataclass(frozen=True)
class Law:
    """Base of the material laws: dataclass fields are the parameters."""

    name: ClassVar[str] = ""
    registry: ClassVar[dict | None] = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name") and cls.registry is not None:
            cls.registry[cls.name] = cls

    def __post_init__(self):
        for f in fields(self):
            _check_finite(f.name, getattr(self, f.name))
            object.__setattr__(self, f.name, float(getattr(self, f.name)))
        self.validate()

    def validate(self) -> None:
        """Raise ValueError naming the parameter if a value is outside its range."""

    @classmethod
    def parameter_names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def parameters(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in self.parameter_names()}

    def values(self, symbolic: bool = False) -> dict:
        """Parameter name -> sympy symbol (`symbolic`) or exact rational of the value."""
        import sympy as sp

        from .symbols import material_symbol

        if symbolic:
            return {name: material_symbol(name) for name in self.parameter_names()}
        return {name: sp.Rational(repr(value)) for name, value in self.parameters().items()}


@dataclass(frozen=True)
class FrictionLaw(Law):
    """A friction law mu(I) (the yield ratio of steady simple shear, (2.7))."""

    registry: ClassVar[dict] = FRICTION_LAWS

    def mu(self, I, prm):
        """mu(I) as a sympy expression, parameters from `prm`."""
        raise NotImplementedError


@dataclass(frozen=True)
class DilatancyLaw(Law):
    """A dilatancy law: steady packing fraction Phi(I) and its inverse I = Psi(phi)."""

    registry: ClassVar[dict] = DILATANCY_LAWS

    def Phi(self, I, prm):
        raise NotImplementedError

    def Psi(self, phi, prm):
        raise NotImplementedError

    def phi_range(self) -> tuple[float, float]:
        """Open interval of phi on which Psi(phi) > 0 (the inertial range)."""
        raise NotImplementedError

    def range_names(self) -> tuple[str, str]:
        """How the ends of :meth:`phi_range` are named in error messages."""
        raise NotImplementedError


@dataclass(frozen=True)
class MuOfI(FrictionLaw):
    """(2.10): mu(I) = mu_s + (mu_d - mu_s)/(I0/I + 1); Table 1 defaults."""

    name: ClassVar[str] = "mu(I)"
    mu_s: float = TABLE1["mu_s"]
    mu_d: float = TABLE1["mu_d"]
    I0: float = TABLE1["I0"]

    def validate(self):
        if not 0 < self.mu_s < self.mu_d:
            raise ValueError(f"`mu_s` must lie in (0, mu_d) = (0, {self.mu_d}); got mu_s={self.mu_s}")
        if not self.mu_d < 1:
            # M < 1 is what makes chi (A18) and the alignment law meaningful
            raise ValueError(f"`mu_d` must lie in (mu_s, 1) = ({self.mu_s}, 1); got {self.mu_d}")
        if not self.I0 > 0:
            raise ValueError(f"`I0` must be > 0; got {self.I0}")

    def mu(self, I, prm):
        # written as mu_s + (mu_d - mu_s) I/(I0 + I): the same function, finite at I = 0
        return prm["mu_s"] + (prm["mu_d"] - prm["mu_s"]) * I / (prm["I0"] + I)


def _check_phi_c(phi_c):
    if not 0 < phi_c < 1:
        raise ValueError(f"`phi_c` must lie in (0, 1); got {phi_c}")


@dataclass(frozen=True)
class LinearDilatancy(DilatancyLaw):
    """(2.11): Phi(I) = phi_c - a I; inverse (2.13) Psi(phi) = (phi_c - phi)/a."""

    name: ClassVar[str] = "linear"
    phi_c: float = TABLE1["phi_c"]
    a: float = TABLE1["a"]

    def validate(self):
        _check_phi_c(self.phi_c)
        if not self.a > 0:
            raise ValueError(f"`a` must be > 0; got {self.a}")

    def Phi(self, I, prm):
        return prm["phi_c"] - prm["a"] * I

    def Psi(self, phi, prm):
        return (prm["phi_c"] - phi) / prm["a"]

    def phi_range(self):
        return 0.0, self.phi_c

    def range_names(self):
        return "0", "phi_c"


#: defaults of the saturating law (see the module docstring for where they come from)
SATURATING_I_STAR = 1.0
SATURATING_PHI_MIN = round(TABLE1["phi_c"] - TABLE1["a"] * SATURATING_I_STAR, 12)


@dataclass(frozen=True)
class SaturatingDilatancy(DilatancyLaw):
    """Section 2's alternative Phi(I) = phi_c - (phi_c - phi_min)/(I_*/I + 1) > phi_min."""

    name: ClassVar[str] = "saturating"
    phi_c: float = TABLE1["phi_c"]
    phi_min: float = SATURATING_PHI_MIN
    I_star: float = SATURATING_I_STAR

    def validate(self):
        _check_phi_c(self.phi_c)
        if not 0 < self.phi_min < self.phi_c:
            raise ValueError(f"`phi_min` must lie in (0, phi_c) = (0, {self.phi_c}); got {self.phi_min}")
        if not self.I_star > 0:
            raise ValueError(f"`I_star` must be > 0; got {self.I_star}")

    def Phi(self, I, prm):
        return prm["phi_c"] - (prm["phi_c"] - prm["phi_min"]) / (prm["I_star"] / I + 1)

    def Psi(self, phi, prm):
        return prm["I_star"] * (prm["phi_c"] - phi) / (phi - prm["phi_min"])

    def phi_range(self):
        return self.phi_min, self.phi_c

    def range_names(self):
        return "phi_min", "phi_c"
