"""``Material``: a friction law mu(I) and a dilatancy law Phi(I)/Psi(phi), Table 1 by default.

The material functions the rheologies use are derived from the two laws:

.. math::
    I = \\Psi(\\phi) \\ (\\text{inverse of } \\Phi), \\qquad M(\\phi) = \\mu(\\Psi(\\phi)) \\quad (A11a).

Symbolic versions (:meth:`Material.symbolic_M`, :meth:`Material.symbolic_Psi`) are the
definition; the numeric ones (:meth:`Material.mu`, ``Phi``, ``Psi``, ``M``) are generated
from them and cached on disk with the kernels (:mod:`icidr_pde.rheology.codegen`).
"""

from __future__ import annotations

import numpy as np

from ..validation import shown
from .laws import DILATANCY_LAWS, FRICTION_LAWS, DilatancyLaw, FrictionLaw, LinearDilatancy, MuOfI

__all__ = ["Material", "mu_of_I"]

_DEFAULT_FRICTION, _DEFAULT_DILATANCY = MuOfI.name, LinearDilatancy.name


def _registered(registry: dict, spec, default=None):
    """The registry's entry for the name `spec`; `default` for anything that is not a name
    (a list from a law file is unhashable: no lookup of it)."""
    return registry.get(spec, default) if isinstance(spec, str) else default


def _law(kind: str, spec, registry: dict, base: type, params: dict):
    """The law instance of `spec` (a name, a class or an instance) with `params` applied."""
    if isinstance(spec, base):
        if params:
            raise ValueError(f"parameters {sorted(params)} cannot be combined with a ready "
                             f"{kind} law instance {spec!r}")
        return spec
    cls = spec if isinstance(spec, type) and issubclass(spec, base) else _registered(registry, spec)
    if cls is None:
        raise ValueError(f"`{kind}` must be one of {sorted(registry)} (or a {base.__name__}); "
                         f"got {shown(spec)}")
    return cls(**params)


class Material:
    """Material parameters and laws of (2.10)-(2.13); defaults are the paper's Table 1.

    Args:
        friction: friction law mu(I): a name of :data:`~icidr_pde.rheology.laws.FRICTION_LAWS`
            ('mu(I)', (2.10)), a law class or instance
        dilatancy: dilatancy law: 'linear' ((2.11), default), 'saturating' (section 2's
            Phi(I) = phi_c - (phi_c - phi_min)/(I_*/I + 1)), a law class or instance
        **parameters: parameters of those laws by name, e.g. mu_s, mu_d, I0 (friction),
            phi_c, a (linear) or phi_c, phi_min, I_star (saturating); others keep their defaults

    Parameters are read as attributes (``material.mu_s``); ``params`` is the tuple of
    values in the order compiled kernels take them (friction parameters, then dilatancy).
    """

    __slots__ = ("friction", "dilatancy")

    def __init__(self, *, friction=_DEFAULT_FRICTION, dilatancy=_DEFAULT_DILATANCY, **parameters):
        laws = {}
        for kind, spec, registry, base in (("friction", friction, FRICTION_LAWS, FrictionLaw),
                                           ("dilatancy", dilatancy, DILATANCY_LAWS, DilatancyLaw)):
            names = (spec if isinstance(spec, base) else
                     (spec if isinstance(spec, type) else _registered(registry, spec, base))).parameter_names()
            mine = {k: parameters.pop(k) for k in list(parameters) if k in names}
            laws[kind] = _law(kind, spec, registry, base, mine)
        if parameters:
            valid = laws["friction"].parameter_names() + laws["dilatancy"].parameter_names()
            raise ValueError(f"unknown Material parameter(s) {sorted(parameters)}; valid for these "
                             f"laws: {list(valid)}")
        object.__setattr__(self, "friction", laws["friction"])
        object.__setattr__(self, "dilatancy", laws["dilatancy"])

    def __setattr__(self, name, value):
        raise AttributeError("Material is immutable; create a new one")

    def __getattr__(self, name):
        for law in (object.__getattribute__(self, "friction"), object.__getattribute__(self, "dilatancy")):
            if name in law.parameter_names():
                return getattr(law, name)
        raise AttributeError(f"Material has no attribute or parameter {name!r}")

    def __eq__(self, other):
        return isinstance(other, Material) and (self.friction, self.dilatancy) == (other.friction,
                                                                                   other.dilatancy)

    def __hash__(self):
        return hash((self.friction, self.dilatancy))

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.to_dict().items())
        return f"Material({args})"

    def __reduce__(self):
        return (_rebuild, (self.to_dict(),))

    # --- parameters -------------------------------------------------------------------

    def parameter_names(self) -> tuple[str, ...]:
        return self.friction.parameter_names() + self.dilatancy.parameter_names()

    @property
    def params(self) -> tuple[float, ...]:
        """Parameter values as a plain tuple, the form compiled kernels take."""
        return tuple(float(getattr(self, n)) for n in self.parameter_names())

    def to_dict(self) -> dict:
        """Parameters by name, plus the law names where they are not the defaults."""
        out = {}
        if self.friction.name != _DEFAULT_FRICTION:
            out["friction"] = self.friction.name
        if self.dilatancy.name != _DEFAULT_DILATANCY:
            out["dilatancy"] = self.dilatancy.name
        out.update(self.friction.parameters())
        out.update(self.dilatancy.parameters())
        return out

    def law_key(self) -> tuple[type, type]:
        """What the generated kernels depend on: the law classes (values are arguments)."""
        return type(self.friction), type(self.dilatancy)

    # --- symbolic definition ------------------------------------------------------------

    def values(self, symbolic: bool = False) -> dict:
        """Parameter name -> sympy symbol (`symbolic`) or exact rational value."""
        return {**self.friction.values(symbolic), **self.dilatancy.values(symbolic)}

    def symbolic_mu(self, I, symbolic: bool = False):
        return self.friction.mu(I, self.values(symbolic))

    def symbolic_Phi(self, I, symbolic: bool = False):
        return self.dilatancy.Phi(I, self.values(symbolic))

    def symbolic_Psi(self, phi, symbolic: bool = False):
        """Psi(phi), the inverse of Phi: the inertial number of steady flow at `phi`."""
        return self.dilatancy.Psi(phi, self.values(symbolic))

    def symbolic_M(self, phi, symbolic: bool = False):
        """M(phi) = mu(Psi(phi)) (A11a)."""
        prm = self.values(symbolic)
        return self.friction.mu(self.dilatancy.Psi(phi, prm), prm)

    # --- numeric ------------------------------------------------------------------------

    @property
    def phi_range(self) -> tuple[float, float]:
        """The open inertial range of phi (where Psi(phi) > 0): (0, phi_c) for (2.11)."""
        return self.dilatancy.phi_range()

    def check_phi(self, phi, name: str = "phi") -> np.ndarray:
        """Return `phi` as an array, raising if it leaves the inertial range."""
        phi = np.asarray(phi, dtype=float)
        lo, hi = self.phi_range
        if not np.all(np.isfinite(phi)) or np.any(phi <= lo) or np.any(phi >= hi):
            if not np.all(np.isfinite(phi)):
                shown = "non-finite values"
            elif phi.size == 1:
                shown = f"{phi.item():g}"
            else:
                shown = f"values in [{phi.min():g}, {phi.max():g}]"
            lo_name, hi_name = self.dilatancy.range_names()
            raise ValueError(f"`{name}` must lie in ({lo_name}, {hi_name}) = ({lo:g}, {hi}); got {shown}")
        return phi

    def _functions(self):
        from .codegen import material_functions

        return material_functions(self)

    def mu(self, I):
        """Friction coefficient mu(I)."""
        return self._functions().mu(np.asarray(I, dtype=float), self.params)

    def Phi(self, I):
        """Steady packing fraction Phi(I)."""
        return self._functions().Phi(np.asarray(I, dtype=float), self.params)

    def Psi(self, phi):
        """Inverse of Phi: I = Psi(phi)."""
        return self._functions().Psi(np.asarray(phi, dtype=float), self.params)

    def M(self, phi):
        """M(phi) = mu(Psi(phi)), (A11a)."""
        return self._functions().M(np.asarray(phi, dtype=float), self.params)


def _rebuild(parameters: dict) -> Material:
    return Material(**parameters)


def mu_of_I(I, mu_s, mu_d, I0):
    """The friction law (2.10) at any parameter values, unvalidated (for least-squares fits).

    Evaluated by the function generated from :meth:`MuOfI.mu`, the one definition of (2.10).
    """
    f = Material()._functions().mu
    rest = Material().params[3:]
    return f(np.asarray(I, dtype=float), (float(mu_s), float(mu_d), float(I0), *rest))
