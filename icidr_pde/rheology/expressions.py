"""The pieces every law defined in sympy is built from: the placeholder symbols by name, an
expression from sympy, a number or a formula (text, read by the safe parser, never ``eval``-ed),
a law function from a callable or an expression, and the text the kernels of a law class depend
on (:meth:`~.base.Rheology.definition_key`). Used by the CIDR laws (:mod:`.cidr`), the direct
laws (:mod:`.direct`) and the law files (:mod:`.law_files`).
"""

from __future__ import annotations

import re

from .base import LawError, Rheology

__all__ = ["pressure_symbol", "law_expression", "placeholder_table", "as_expression", "law_function",
           "function_source", "kernel_source", "identifier"]


def pressure_symbol():
    """The sympy symbol p (pressure), positive."""
    import sympy as sp

    return sp.Symbol("p", positive=True)


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


def placeholder_table() -> dict:
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
        table = placeholder_table()
        names = {n: table[n] for n in argnames}
        names.update({k: v for k, v in s.MATERIAL_SYMBOLS.items() if k not in names})
        return parse_expression(spec, names, where)
    try:
        return sp.sympify(spec, strict=True)
    except sp.SympifyError:
        raise ValueError(f"{where} must be a sympy expression, a number or a formula (text); "
                         f"got {type(spec).__name__}") from None


def law_function(spec, argnames, where="law"):
    """A callable of `argnames` from a callable or a sympy expression (or formula) in the placeholder symbols."""
    if callable(spec):
        return spec
    import sympy as sp

    from . import symbols as s

    expr = as_expression(spec, argnames, where)
    table = placeholder_table()

    def function(*args):
        *values, prm = args
        subs = {table[n]: v for n, v in zip(argnames, values)}
        subs.update({s.MATERIAL_SYMBOLS[k]: v for k, v in prm.items() if k in s.MATERIAL_SYMBOLS})
        return expr.xreplace(subs)

    function.source = sp.srepr(expr)
    return function


def function_source(*functions, extra=""):
    """The text of law functions (their formula, or their source), after `extra`: part of a law's key."""
    import inspect

    parts = [extra]
    for f in functions:
        parts.append(getattr(f, "source", None) or inspect.getsource(f))
    return "\n".join(parts)


def kernel_source(cls, extra=()) -> str:
    """Text the kernels of the law class `cls` depend on: the modules of every Rheology class it
    inherits from, this one (the expressions they are built of) and the modules `extra`."""
    from .codegen import _module_source

    modules = dict.fromkeys(k.__module__ for k in cls.__mro__ if isinstance(k, type) and issubclass(k, Rheology))
    modules.update(dict.fromkeys((__name__, *extra)))
    return "\n".join(_module_source(m) for m in modules if not m.startswith("__")) + cls.__qualname__


def identifier(name: str) -> str:
    """`name` as a Python identifier (the name of a law class built at run time)."""
    return re.sub(r"\W", "_", name)
