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
:class:`DirectLaw`: (4.3)-(4.5) do not apply to it; only the stability analysis does.

A law written in a file (:func:`load_law_file`) defines ``yield_function`` and
``dilatancy_function`` (or ``pressure`` and ``shear_stress``) of
(p, I, phi, M, Psi, prm) resp. (phi, div_u, norm_S, M, Psi, prm); M = mu(Psi(phi)) and
Psi = Psi(phi) of the material, prm the material parameters by name. Such a Python file is a
program and loading it runs it; a declarative ``*.toml`` file (:mod:`.declarative`) gives the
same law as formulas read by a whitelist, nothing run (docs/security.md).
"""

from __future__ import annotations

import pathlib
import re

import numpy as np

from .base import RHEOLOGIES, LawError, Rheology, ill_defined, sample_states
from ..validation import input_file
from .material import Material

__all__ = ["CIDRLaw", "DirectLaw", "LawError", "define_cidr_law", "define_direct_law", "load_law_file",
           "sample_states", "ill_defined", "pressure_symbol", "is_file_law", "get_rheology", "define_rheology"]


def pressure_symbol():
    """The sympy symbol p (pressure), positive."""
    import sympy as sp

    return sp.Symbol("p", positive=True)


def _sqrt_p_symbol():
    import sympy as sp

    return sp.Symbol("q", positive=True)


def law_expression(law, function: str, *args):
    """The sympy expression `law`.`function`(*args) returns; text is refused (sympify would eval it)."""
    import sympy as sp

    value = getattr(law, function)(*args)
    try:
        return sp.sympify(value, strict=True)
    except sp.SympifyError:
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        raise LawError(law.name, f"{function}() must return a sympy expression or a number; got "
                                 f"{type(value).__name__} {shown} (write a formula as a declarative .toml law)") from None


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

def _mro_source(cls) -> str:
    """Text the kernels of `cls` depend on: the modules of every Rheology class it inherits from."""
    from .codegen import _module_source

    modules = dict.fromkeys(k.__module__ for k in cls.__mro__ if isinstance(k, type) and issubclass(k, Rheology))
    if issubclass(cls, CIDRLaw):  # the scalar solve's source is part of an implicit law's kernels
        modules[f"{__package__}.implicit"] = None
    return "\n".join(_module_source(m) for m in modules if not m.startswith("__")) + cls.__qualname__


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
        return _mro_source(cls)

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


class DirectLaw(Rheology):
    """A law given directly as p and ||tau|| on invariants; (4.3)-(4.5) do not apply.

    Subclasses implement :meth:`pressure` and :meth:`shear_stress` (||tau||), or override
    :meth:`law` with (p, c) directly.
    """

    kind = "direct"

    @classmethod
    def definition_key(cls) -> str:
        return _mro_source(cls)

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


# --- laws built at run time -----------------------------------------------------------------

def _placeholder_table() -> dict:
    """Name -> symbol of every argument a law function takes (:mod:`.symbols`, p of :func:`pressure_symbol`)."""
    from . import symbols as s

    return {"p": pressure_symbol(), "I": s.I, "phi": s.phi, "div_u": s.div_u, "norm_S": s.norm_S,
            "M": s.M, "Psi": s.Psi}


def as_expression(spec, argnames, where: str):
    """A sympy expression from a sympy object or number, or from text by the safe parser
    (:func:`.declarative.parse_expression`: the names `argnames` and the material parameters;
    never ``sympify`` of text, which is ``eval``)."""
    import sympy as sp

    from . import symbols as s
    from .declarative import parse_expression

    if isinstance(spec, str):
        table = _placeholder_table()
        names = {n: table[n] for n in argnames}
        names.update({k: v for k, v in s.MATERIAL_SYMBOLS.items() if k not in names})
        return parse_expression(spec, names, where)
    try:
        return sp.sympify(spec, strict=True)
    except sp.SympifyError:
        raise ValueError(f"{where} must be a sympy expression, a number or a formula (text); "
                         f"got {type(spec).__name__}") from None


def _as_function(spec, argnames, where="law"):
    """A callable of `argnames` from a callable or a sympy expression (or formula) in the placeholder symbols."""
    if callable(spec):
        return spec
    import sympy as sp

    from . import symbols as s

    expr = as_expression(spec, argnames, where)
    table = _placeholder_table()

    def function(*args):
        *values, prm = args
        subs = {table[n]: v for n, v in zip(argnames, values)}
        subs.update({s.MATERIAL_SYMBOLS[k]: v for k, v in prm.items() if k in s.MATERIAL_SYMBOLS})
        return expr.xreplace(subs)

    function.source = sp.srepr(expr)
    return function


def _key_of(*functions, extra=""):
    import inspect

    parts = [extra]
    for f in functions:
        parts.append(getattr(f, "source", None) or inspect.getsource(f))
    return "\n".join(parts)


def check_law_name(name) -> None:
    """A law defined at run time needs a name of its own: a built-in law's name is refused."""
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_\-]*", name):
        raise ValueError(f"`name` must start with a letter and contain letters, digits, '_' or '-'; got {name!r}")
    taken = RHEOLOGIES.get(name)
    if taken is not None and not taken.defined_at_run_time:
        builtin = sorted(k for k, v in RHEOLOGIES.items() if not v.defined_at_run_time)
        raise ValueError(f"`name` {name!r} is a built-in law's; a law defined at run time needs a name of its "
                         f"own (built-in: {', '.join(builtin)})")


def _register(name, cls, register):
    check_law_name(name)
    cls.name = name
    cls.defined_at_run_time = True
    if register:
        RHEOLOGIES[name] = cls
    return cls


def define_cidr_law(name: str, yield_function, dilatancy_function, *, label=None, material: Material | None = None,
                    register: bool = True, key: str | None = None, equation_of_state: str = "auto") -> type:
    """A :class:`CIDRLaw` class from Y and f (callables of (p, I, phi, M, Psi, prm) or sympy
    expressions in the symbols p, I, phi, M, Psi and material parameters); registered as `name`.
    `equation_of_state` as :attr:`CIDRLaw.equation_of_state` ('auto' or 'scalar')."""
    if equation_of_state not in ("auto", "scalar"):
        raise ValueError(f"`equation_of_state` must be 'auto' or 'scalar'; got {equation_of_state!r}")
    check_law_name(name)
    Y = _as_function(yield_function, ("p", "I", "phi", "M", "Psi"), "`yield_function`")
    f = _as_function(dilatancy_function, ("p", "I", "phi", "M", "Psi"), "`dilatancy_function`")
    definition = key or _key_of(Y, f, extra=name)
    body = {
        "yield_function": lambda self, p, I, phi, M, Psi, prm: Y(p, I, phi, M, Psi, prm),  # noqa: E741
        "dilatancy_function": lambda self, p, I, phi, M, Psi, prm: f(p, I, phi, M, Psi, prm),  # noqa: E741
        "definition_key": classmethod(lambda cls: definition + equation_of_state + _mro_source(CIDRLaw)),
        "label": label or name, "__doc__": f"CIDR law {name!r} defined at run time.",
        "equation_of_state": equation_of_state,
    }
    if material is not None:
        body["default_material"] = classmethod(lambda cls: material)
    return _register(name, type(f"CIDRLaw_{_ident(name)}", (CIDRLaw,), body), register)


def define_direct_law(name: str, pressure, shear_stress, *, label=None, material: Material | None = None,
                      register: bool = True, key: str | None = None) -> type:
    """A :class:`DirectLaw` class from p and ||tau|| (callables of (phi, div_u, norm_S, M, Psi, prm)
    or sympy expressions in phi, div_u, norm_S, M, Psi and material parameters)."""
    check_law_name(name)
    P = _as_function(pressure, ("phi", "div_u", "norm_S", "M", "Psi"), "`pressure`")
    T = _as_function(shear_stress, ("phi", "div_u", "norm_S", "M", "Psi"), "`shear_stress`")
    definition = key or _key_of(P, T, extra=name)
    body = {
        "pressure": lambda self, phi, div_u, norm_S, M, Psi, prm: P(phi, div_u, norm_S, M, Psi, prm),
        "shear_stress": lambda self, phi, div_u, norm_S, M, Psi, prm: T(phi, div_u, norm_S, M, Psi, prm),
        "definition_key": classmethod(lambda cls: definition + _mro_source(DirectLaw)),
        "label": label or name, "__doc__": f"Direct law {name!r} defined at run time.",
    }
    if material is not None:
        body["default_material"] = classmethod(lambda cls: material)
    return _register(name, type(f"DirectLaw_{_ident(name)}", (DirectLaw,), body), register)


def _ident(name: str) -> str:
    return re.sub(r"\W", "_", name)


def is_file_law(spec) -> bool:
    """True if `spec` names a law file (Python ``*.py`` or declarative ``*.toml``) rather than a registered law."""
    from .declarative import is_declarative_law

    return isinstance(spec, (str, pathlib.Path)) and (str(spec).endswith(".py") or is_declarative_law(spec))


#: what a Python law file defines: (function names, their argument names, the law's kind)
_FILE_LAWS = ((("yield_function", "dilatancy_function"), ("p", "I", "phi", "M", "Psi"), "cidr"),
              (("pressure", "shear_stress"), ("phi", "div_u", "norm_S", "M", "Psi"), "direct"))


def load_law_file(path) -> type:
    """The law class of a law file; registered under its ``name`` (default: the file's stem).

    A declarative file (``*.toml``, :mod:`.declarative`) is data: its formulas are parsed by a
    whitelist, nothing in it is run. **A Python file (``*.py``) is a program: loading it runs
    it** (``runpy``), with every right of the user, before anything can be checked; load only
    Python law files you would run yourself, and share laws as ``*.toml``.

    The Python file defines ``yield_function(p, I, phi, M, Psi, prm)`` and
    ``dilatancy_function(p, I, phi, M, Psi, prm)`` (a CIDR law), or ``pressure`` and
    ``shear_stress`` of (phi, div_u, norm_S, M, Psi, prm) (a direct law), returning sympy
    expressions; optional ``name``, ``label``, ``material`` (a dict of Material arguments).
    Every error (the file's own, at its run or at the first call of its functions, a name
    that is a built-in law's, a symbol that is not a law's) is one ValueError line naming the file.
    """
    from .declarative import is_declarative_law, load_declarative_law

    if is_declarative_law(path):
        return load_declarative_law(path)
    path = pathlib.Path(path)
    where = f"Python law file {str(path)!r} (it was run)"
    input_file("rheology", path)
    namespace = _run_law_file(path, where)
    name = namespace.get("name", path.stem)
    label = namespace.get("label")
    material = namespace.get("material")
    try:
        if isinstance(material, dict):
            material = Material(**material)
        elif material is not None and not isinstance(material, Material):
            raise ValueError(f"`material` must be a dict of Material arguments; got {type(material).__name__}")
        check_law_name(name)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None
    key = f"file {name}\n{path.read_text()}"
    for functions, argnames, kind in _FILE_LAWS:
        if all(f in namespace for f in functions):
            _probe(namespace, functions, argnames, material or Material(), where)
            define = define_cidr_law if kind == "cidr" else define_direct_law
            return define(name, *(namespace[f] for f in functions), label=label, material=material, key=key)
    raise ValueError(f"{where} must define yield_function and dilatancy_function "
                     "(a CIDR law) or pressure and shear_stress (a direct law)")


def _run_law_file(path, where) -> dict:
    """The namespace of the Python file `path`, run; its errors (sys.exit too) as one ValueError line."""
    import runpy

    try:
        return runpy.run_path(str(path))
    except SyntaxError as err:
        raise ValueError(f"Python law file {str(path)!r}: syntax error at line {err.lineno}: {err.msg} "
                         "(nothing in it was run)") from None
    except SystemExit as err:
        raise ValueError(f"{where}: it called sys.exit({err.code!r}) instead of defining a law") from None
    except Exception as err:  # noqa: BLE001  (any error of the user's program, named in one line)
        raise ValueError(f"{where}: it raised {_one_line(err)}") from None


def _one_line(err) -> str:
    text = " ".join(str(err).split())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def _probe(namespace, functions, argnames, material, where) -> None:
    """Call the file's law functions once on the placeholder symbols: their errors, a result that
    is not an expression, not finite (nan, zoo, oo) or in a symbol that is not the law's, as one line."""
    import sympy as sp
    from sympy.core.function import AppliedUndef

    table = _placeholder_table()
    args = [table[a] for a in argnames]
    prm = material.values(symbolic=True)
    allowed = set(args) | set(prm.values())
    for function in functions:
        try:
            value = namespace[function](*args, prm)
        except Exception as err:  # noqa: BLE001
            raise ValueError(f"{where}: {function}() raised {_one_line(err)}") from None
        try:
            expr = sp.sympify(value, strict=True)
        except sp.SympifyError:
            raise ValueError(f"{where}: {function}() must return a sympy expression or a number; got "
                             f"{type(value).__name__}") from None
        bad = [a for a in (sp.nan, sp.zoo, sp.oo, -sp.oo) if expr.has(a)]
        if bad:
            raise ValueError(f"{where}: {function}() is not finite (it is {sp.sstr(expr)[:80]})")
        strangers = sorted(map(str, (expr.free_symbols - allowed) | expr.atoms(AppliedUndef)))
        if strangers:
            raise ValueError(f"{where}: {function}() uses {', '.join(strangers)}, not a symbol of the law; "
                             f"its symbols: {', '.join(argnames)} and the material's "
                             f"{', '.join(material.parameter_names())} (as prm[...])")


def get_rheology(name, material: Material | None = None) -> Rheology:
    """The rheology registered as `name` (see :data:`RHEOLOGIES`), a law file ``*.toml`` or
    ``*.py`` (:func:`~icidr_pde.rheology.cidr.load_law_file`: a ``*.py`` file is run, it is a
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
    cls.name = name
    cls.defined_at_run_time = True
    if register:
        RHEOLOGIES[name] = cls
    return cls
