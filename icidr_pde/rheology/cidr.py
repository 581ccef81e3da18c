"""CIDR laws from a yield function Y(p, I, phi) and a dilatancy function f(p, I, phi) (section 4).

A CIDR law is (4.1) ||tau|| = Y(p, I, phi) and the flow rule (4.2) div u = 2 f(p, I, phi) ||S||,
with the inertial number (2.9) I = 2 ||S||/sqrt(p) (d = rho_* = 1, scalings (3.12)) and the
alignment law (2.6). The workbench turns (Y, f) into a :class:`~.base.Rheology` on invariants:

* **equation of state.** With q = sqrt(p) and I = 2||S||/q, the flow rule is one equation
  for q given (phi, div u, ||S||). It is solved by sympy in closed form (as (4.12) follows
  from (4.9)); the root taken is the one positive on the sample of :func:`sample_states`
  (the others are not positive anywhere there, or the law is rejected). Where that root is
  not positive the flow rule has no positive solution: :meth:`CIDRLaw.admissibility` reports
  such a state, and such a law is for the stability analysis only (it is not run).
  A subclass may also give the closed form itself (:meth:`CIDRLaw.closed_form`, e.g. a
  cancellation-free one): it is then *checked* against the flow rule and the yield law
  (:meth:`CIDRLaw.verify_closed_form`), not trusted;
  where sympy finds no root in closed form (or ``equation_of_state = "scalar"`` asks for it),
  sqrt(p) is the root of the flow-rule residual F(q) = div u - 2||S|| f(q^2, 2||S||/q, phi),
  a sympy function whose derivatives are the implicit function theorem, solved in the
  compiled kernels by a safeguarded (bracketed) Newton iteration (:mod:`.implicit`);
* **stress.** ||tau|| = Y at that p, and tau = (Y/||S||) S (2.6): c = Y/||S||, simplified
  so that it stays finite as ||S|| -> 0 wherever the law allows;
* **stable form.** For the kernels, a difference sqrt(A) - B that cancels in floating point
  when B > 0 is rewritten as (A - B^2)/(sqrt(A) + B) there (the same function).

Everything numeric (kernels, Jacobians for every discretization, the stability toolkit)
is then generated from :meth:`~.base.Rheology.law` as for any other rheology: the
derivatives are sympy's, none is written by hand.

A law given directly as p and ||tau|| on invariants (like mu(I),Phi(I)) is a
:class:`~.direct.DirectLaw`: (4.3)-(4.5) do not apply to it; only the stability analysis does.

A law written in a file (:func:`~.law_files.load_law_file`) defines ``yield_function`` and
``dilatancy_function`` (or ``pressure`` and ``shear_stress``) of
(p, I, phi, M, Psi, prm) resp. (phi, div_u, norm_S, M, Psi, prm); M = mu(Psi(phi)) and
Psi = Psi(phi) of the material, prm the material parameters by name. Such a Python file is a
program and loading it runs it; a declarative ``*.toml`` file (:mod:`.declarative`) gives the
same law as formulas read by a whitelist, nothing run (docs/security.md).
"""

from __future__ import annotations

import numpy as np

from .base import LawError, Rheology, ill_defined, sample_states
from .expressions import function_source, identifier, kernel_source, law_expression, law_function, pressure_symbol
from .material import Material
from .registry import check_law_name, register_law

__all__ = ["CIDRLaw", "LawError", "define_cidr_law", "sample_states", "ill_defined", "pressure_symbol"]

#: besides its classes' modules, the kernels of a CIDR law depend on the scalar solve's source
#: (:mod:`.implicit`, the root of an implicit law)
IMPLICIT_SOURCE = (f"{__package__}.implicit",)


def _sqrt_p_symbol():
    import sympy as sp

    return sp.Symbol("q", positive=True)


# --- the stable rewriting ----------------------------------------------------------------

def cancellation_free(expr):
    """Rewrite sqrt(A) - B (B > 0, cancelling) as (A - B^2)/(sqrt(A) + B): the same function.

    Applied to every sum of one square root and other terms whose square cancels the
    leading part of A (checked: A - B^2 has fewer terms than A).
    """
    import sympy as sp

    def rewrite(e):
        if not e.is_Add:
            return e
        roots = [t for t in e.args if t.is_Pow and t.exp == sp.S.Half]
        if len(roots) != 1:
            return e
        r = roots[0]
        rest = e - r
        diff = sp.expand(r.base - rest**2)
        if len(sp.Add.make_args(diff)) >= len(sp.Add.make_args(sp.expand(r.base))):
            return e
        return sp.Piecewise((diff / (r - rest), rest < 0), (e, True))

    return expr.replace(lambda e: e.is_Add, rewrite)


# --- CIDR laws ----------------------------------------------------------------------------

class CIDRLaw(Rheology):
    """A CIDR law (4.1)-(4.2) from Y(p, I, phi) and f(p, I, phi); see the module docstring.

    Subclasses implement :meth:`yield_function` and :meth:`dilatancy_function` (sympy, in
    terms of M = mu(Psi(phi)), Psi = Psi(phi) and the parameters `prm`), optionally
    :meth:`closed_form`, and set ``name``/``label``.
    """

    kind = "cidr"
    #: "auto": a closed-form root where sympy finds one, else the scalar solve; "scalar": always
    #: the scalar solve (:mod:`.implicit`), e.g. where the closed form needs complex arithmetic
    equation_of_state: str = "auto"

    def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        """Y(p, I, phi) of (4.1), a sympy expression."""
        raise NotImplementedError

    def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
        """f(p, I, phi) of (4.2), a sympy expression."""
        raise NotImplementedError

    def closed_form(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        """Optional (p, c) in closed form (checked by :meth:`verify_closed_form`); None: derive."""
        return None

    @classmethod
    def has_closed_form(cls) -> bool:
        """True if the law gives its own closed form (decided without sympy: a cached run imports none)."""
        return cls.closed_form is not CIDRLaw.closed_form

    @classmethod
    def definition_key(cls) -> str:
        return kernel_source(cls, IMPLICIT_SOURCE)

    # --- derivation, in placeholders ----------------------------------------------------

    def _placeholders(self):
        from . import symbols as s

        return s.phi, s.div_u, s.norm_S, s.M, s.Psi, self.material.values(symbolic=True)

    def _derived(self):
        """(q, c) = (sqrt(p), ||tau||/||S||) solving the flow rule, in placeholder symbols (cached)."""
        cache = type(self).__dict__.get("_derivation_cache")
        if cache is None:
            cache = {}
            type(self)._derivation_cache = cache
        key = type(self.material.friction), type(self.material.dilatancy)
        if key not in cache:
            cache[key] = self._derive()
        return cache[key]

    def _derive(self):
        import sympy as sp

        phi, div, S, M, Psi, prm = self._placeholders()
        q = _sqrt_p_symbol()
        I = 2 * S / q  # noqa: E741  (2.9) with d = rho_* = 1
        f = law_expression(self, "dilatancy_function", q**2, I, phi, M, Psi, prm)
        Y = law_expression(self, "yield_function", q**2, I, phi, M, Psi, prm)
        if self.equation_of_state not in ("auto", "scalar"):
            raise ValueError(f"`equation_of_state` must be 'auto' or 'scalar'; got {self.equation_of_state!r}")
        roots = []
        if self.equation_of_state == "auto":
            numerator = sp.numer(sp.together(div - 2 * f * S))
            try:
                roots = sp.solve(numerator, q)
            except NotImplementedError:
                roots = []
            roots = [r for r in roots if not r.has(sp.I)]
        if not roots:
            return self._implicit_root(f, Y)
        q_root = self._positive_root(roots, None)
        c = sp.simplify(Y.subs(q, q_root) / S) if not Y.has(q) else sp.simplify((Y / S).subs(q, q_root))
        return q_root, c

    def _implicit_root(self, f, Y):
        """(q, c) with q the implicit root of the flow-rule residual (:mod:`.implicit`), in placeholders."""
        import sympy as sp

        from .implicit import implicit_root_class

        phi, div, S, M, Psi, prm = self._placeholders()
        q = _sqrt_p_symbol()
        flux = 2 * S * f
        if sp.count_ops(flux) <= 200:
            flux = sp.expand(flux)  # e.g. iCIDR: 2||S|| f = M||S||^2/(q Psi) - M Psi q/4, finite at ||S|| = 0
        F = div - flux
        if not F.has(q):
            raise LawError(self.name, "the flow rule (4.2) with (2.9) has no closed-form solution for p and "
                           "does not depend on p (no scalar solve possible)")
        names = self.material.parameter_names()
        args = (phi, div, S, M, Psi, *[prm[k] for k in names])
        root = implicit_root_class(self.name or type(self).__name__, F, q, args)(*args)
        c = sp.simplify(Y / S)
        return root, c.xreplace({q: root})

    def is_implicit(self) -> bool:
        """True if sqrt(p) is the scalar solve's root (no closed form); needs sympy."""
        from .implicit import ImplicitRoot

        if self.has_closed_form():
            return False
        q, _ = self._derived()
        return isinstance(q, ImplicitRoot)

    def _numeric_placeholders(self):
        """Values of the placeholders on the sample (M, Psi from the material)."""
        phis, divs, Ss = sample_states(self.material.phi_range)
        return phis, divs, Ss, self.material.M(phis), self.material.Psi(phis)

    def _lambdify(self, expr):
        import sympy as sp

        phi, div, S, M, Psi, prm = self._placeholders()
        names = self.material.parameter_names()
        f = sp.lambdify((phi, div, S, M, Psi, *[prm[k] for k in names]), expr, modules="numpy")
        phis, divs, Ss, Ms, Psis = self._numeric_placeholders()
        with np.errstate(all="ignore"):
            out = f(phis, divs, Ss, Ms, Psis, *self.material.params)
        return np.broadcast_to(np.asarray(out, dtype=complex), phis.shape)

    def _positive_root(self, roots, flow):
        best, best_count = None, -1
        for r in roots:
            v = self._lambdify(r)
            count = int(np.sum((np.abs(v.imag) <= 1e-12 * np.abs(v)) & (v.real > 0)))
            if count > best_count:
                best, best_count = r, count
        if best_count <= 0:
            phis, divs, Ss, _, _ = self._numeric_placeholders()
            raise LawError(self.name, "the flow rule (4.2) with (2.9) has no positive solution for p",
                           {"phi": phis[0], "div_u": divs[0], "norm_S": Ss[0]})
        return best

    def inadmissible(self) -> np.ndarray:
        """Mask of :func:`sample_states` where the flow rule has no positive solution for p."""
        from .implicit import ImplicitRoot

        q, _ = self._derived()
        if isinstance(q, ImplicitRoot):
            phis, divs, Ss, Ms, Psis = self._numeric_placeholders()
            _, failed = q.solve(phis, divs, Ss, Ms, Psis, *self.material.params, raise_on_failure=False)
            return np.asarray(failed, dtype=bool)
        v = self._lambdify(q)
        bad = ~((np.abs(v.imag) <= 1e-12 * np.maximum(np.abs(v), 1e-300)) & (v.real > 0))
        _, divs, Ss, _, _ = self._numeric_placeholders()
        return bad & ~((Ss == Ss.min()) & (divs >= 0) & (np.abs(v) < 1e-12))  # p = 0 where allowed (4.13)

    def admissibility(self):
        """None, or a state (dict) of the sample where the flow rule has no positive solution for p."""
        bad = self.inadmissible()
        if not np.any(bad):
            return None
        phis, divs, Ss, _, _ = self._numeric_placeholders()
        i = int(np.argmax(bad))
        return {"phi": float(phis[i]), "div_u": float(divs[i]), "norm_S": float(Ss[i])}

    def check_runnable(self) -> None:
        """Raise LawError (naming a state) if the flow rule has no positive p somewhere on the sample.

        A law with a given closed form is checked by :meth:`verify_closed_form` (tests, ``law check``);
        here only derived roots are examined, so running iCIDR costs no sympy work.
        """
        if not self.has_closed_form():
            bad = self.admissibility()
            if bad is not None:
                raise LawError(self.name, "the flow rule (4.2) with (2.9) has no positive solution for p, so the "
                               "law cannot be run (use it in the stability analysis only)", bad)
        super().check_runnable()

    def verify_closed_form(self, rtol: float = 1e-10) -> None:
        """Raise LawError unless :meth:`closed_form` equals the derived (p, c) on the sample."""
        phi, div, S, M, Psi, prm = self._placeholders()
        given = self.closed_form(phi, div, S, M, Psi, prm)
        if given is None:
            return
        q, c = self._derived()
        for name, mine, theirs in (("p", given[0], q**2), ("c", given[1], c)):
            a, b = self._lambdify(mine), self._lambdify(theirs)
            ok = np.abs(a - b) <= rtol * np.maximum(np.abs(b), 1e-300) + 1e-300
            ok |= ~np.isfinite(b)
            if not np.all(ok):
                phis, divs, Ss, _, _ = self._numeric_placeholders()
                i = int(np.argmin(ok))
                raise LawError(self.name, f"closed_form() {name} does not solve the flow rule (4.2) with (2.9) "
                               "and (4.1)", {"phi": phis[i], "div_u": divs[i], "norm_S": Ss[i]},
                               f"given {a[i].real:.6g}, derived {b[i].real:.6g}")

    def law(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
        given = self.closed_form(phi, div_u, norm_S, M, Psi, prm, stable=stable)
        if given is not None:
            return given
        q, c = self._derived()
        if stable:
            q, c = cancellation_free(q), cancellation_free(c)
        from . import symbols as s

        subs = {s.phi: phi, s.div_u: div_u, s.norm_S: norm_S, s.M: M, s.Psi: Psi}
        own = self.material.values(symbolic=True)
        subs.update({own[k]: v for k, v in prm.items() if k in own})
        return (q**2).xreplace(subs), c.xreplace(subs)

    def symbolic_yield(self, symbolic_material: bool = True):
        """(Y, f) in the symbols p, I, phi and placeholders M, Psi (parameters symbolic if asked)."""
        from . import symbols as s

        prm = self.material.values(symbolic=symbolic_material)
        p = pressure_symbol()
        return (self.yield_function(p, s.I, s.phi, s.M, s.Psi, prm),
                self.dilatancy_function(p, s.I, s.phi, s.M, s.Psi, prm))


def define_cidr_law(name: str, yield_function, dilatancy_function, *, label=None, material: Material | None = None,
                    register: bool = True, key: str | None = None, equation_of_state: str = "auto") -> type:
    """A :class:`CIDRLaw` class from Y and f (callables of (p, I, phi, M, Psi, prm) or sympy
    expressions in the symbols p, I, phi, M, Psi and material parameters); registered as `name`.
    `equation_of_state` as :attr:`CIDRLaw.equation_of_state` ('auto' or 'scalar')."""
    if equation_of_state not in ("auto", "scalar"):
        raise ValueError(f"`equation_of_state` must be 'auto' or 'scalar'; got {equation_of_state!r}")
    check_law_name(name)
    Y = law_function(yield_function, ("p", "I", "phi", "M", "Psi"), "`yield_function`")
    f = law_function(dilatancy_function, ("p", "I", "phi", "M", "Psi"), "`dilatancy_function`")
    definition = key or function_source(Y, f, extra=name)
    body = {
        "yield_function": lambda self, p, I, phi, M, Psi, prm: Y(p, I, phi, M, Psi, prm),  # noqa: E741
        "dilatancy_function": lambda self, p, I, phi, M, Psi, prm: f(p, I, phi, M, Psi, prm),  # noqa: E741
        "definition_key": classmethod(
            lambda cls: definition + equation_of_state + kernel_source(CIDRLaw, IMPLICIT_SOURCE)),
        "label": label or name, "__doc__": f"CIDR law {name!r} defined at run time.",
        "equation_of_state": equation_of_state,
    }
    if material is not None:
        body["default_material"] = classmethod(lambda cls: material)
    return register_law(name, type(f"CIDRLaw_{identifier(name)}", (CIDRLaw,), body), register)
