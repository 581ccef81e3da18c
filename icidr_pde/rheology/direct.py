"""Laws given directly as the pressure p and the shear stress ||tau|| on invariants (like
mu(I),Phi(I), :mod:`.mui`): (4.3)-(4.5) do not apply to them, only the stability analysis does.

:class:`DirectLaw` takes p and ||tau|| (c = ||tau||/||S||); :func:`define_direct_law` builds one
at run time from functions or formulas, :func:`define_rheology` a law from p and c themselves.
"""

from __future__ import annotations

from .base import Rheology
from .expressions import as_expression, function_source, identifier, kernel_source, law_expression, law_function
from .material import Material
from .registry import check_law_name, register_law

__all__ = ["DirectLaw", "define_direct_law", "define_rheology"]


class DirectLaw(Rheology):
    """A law given directly as p and ||tau|| on invariants; (4.3)-(4.5) do not apply.

    Subclasses implement :meth:`pressure` and :meth:`shear_stress` (||tau||), or override
    :meth:`law` with (p, c) directly.
    """

    kind = "direct"

    @classmethod
    def definition_key(cls) -> str:
        return kernel_source(cls)

    def pressure(self, phi, div_u, norm_S, M, Psi, prm):
        raise NotImplementedError

    def shear_stress(self, phi, div_u, norm_S, M, Psi, prm):
        raise NotImplementedError

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        import sympy as sp

        from . import symbols as s

        # c = ||tau||/||S||, cancelled in the placeholder symbols (so c stays finite at ||S|| = 0
        # where ||tau|| vanishes like ||S||), then evaluated at the arguments
        own = self.material.values(symbolic=True)
        p = law_expression(self, "pressure", s.phi, s.div_u, s.norm_S, s.M, s.Psi, own)
        c = sp.cancel(law_expression(self, "shear_stress", s.phi, s.div_u, s.norm_S, s.M, s.Psi, own) / s.norm_S)
        subs = {s.phi: phi, s.div_u: div_u, s.norm_S: norm_S, s.M: M, s.Psi: Psi}
        subs.update({own[k]: v for k, v in prm.items() if k in own})
        return p.xreplace(subs), c.xreplace(subs)


def define_direct_law(name: str, pressure, shear_stress, *, label=None, material: Material | None = None,
                      register: bool = True, key: str | None = None) -> type:
    """A :class:`DirectLaw` class from p and ||tau|| (callables of (phi, div_u, norm_S, M, Psi, prm)
    or sympy expressions in phi, div_u, norm_S, M, Psi and material parameters)."""
    check_law_name(name)
    P = law_function(pressure, ("phi", "div_u", "norm_S", "M", "Psi"), "`pressure`")
    T = law_function(shear_stress, ("phi", "div_u", "norm_S", "M", "Psi"), "`shear_stress`")
    definition = key or function_source(P, T, extra=name)
    body = {
        "pressure": lambda self, phi, div_u, norm_S, M, Psi, prm: P(phi, div_u, norm_S, M, Psi, prm),
        "shear_stress": lambda self, phi, div_u, norm_S, M, Psi, prm: T(phi, div_u, norm_S, M, Psi, prm),
        "definition_key": classmethod(lambda cls: definition + kernel_source(DirectLaw)),
        "label": label or name, "__doc__": f"Direct law {name!r} defined at run time.",
    }
    if material is not None:
        body["default_material"] = classmethod(lambda cls: material)
    return register_law(name, type(f"DirectLaw_{identifier(name)}", (DirectLaw,), body), register)


def define_rheology(name: str, p, c, *, label: str | None = None, register: bool = True) -> type:
    """Build (and register) a Rheology class from sympy expressions of the invariants.

    `p` and `c` (tau = c S) are sympy expressions in the symbols of
    :mod:`icidr_pde.rheology.symbols`: ``phi``, ``div_u``, ``norm_S``, the placeholders
    ``M`` = M(phi) and ``Psi`` = Psi(phi), and material parameters
    (``MATERIAL_SYMBOLS``), or formulas (text) in those names, read by the safe parser
    (:func:`~.declarative.parse_expression`; text is never ``sympify``-d, which would ``eval`` it).
    `name` may not be a built-in law's. Kernels are generated and cached like those of the
    built-in rheologies. Returns the class; ``get_rheology(name, material)`` then works.
    """
    import sympy as sp

    from . import symbols as s

    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"`name` must be an identifier-like string; got {name!r}")
    check_law_name(name)
    argnames = ("phi", "div_u", "norm_S", "M", "Psi")
    p, c = as_expression(p, argnames, "`p`"), as_expression(c, argnames, "`c`")
    key = f"{sp.srepr(p)}\n{sp.srepr(c)}"

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        subs = {s.phi: phi, s.div_u: div_u, s.norm_S: norm_S, s.M: M, s.Psi: Psi}
        subs.update({s.MATERIAL_SYMBOLS[k]: v for k, v in prm.items()})
        return p.xreplace(subs), c.xreplace(subs)

    cls = type(f"Rheology_{name}", (Rheology,),
               {"law": law, "label": label or name, "definition_key": classmethod(lambda cls: key),
                "__doc__": f"Rheology {name!r}: p = {p}, c = {c} (tau = c S)."})
    return register_law(name, cls, register)
