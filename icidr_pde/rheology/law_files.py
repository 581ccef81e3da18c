"""Laws written in files: a Python file (``*.py``, a program: loading it runs it) or a
declarative file (``*.toml``, :mod:`.declarative`: formulas read by a whitelist, nothing run).

:func:`load_law_file` turns either into a law class (:func:`~.cidr.define_cidr_law`,
:func:`~.direct.define_direct_law`) registered under the file's ``name``; :func:`is_file_law`
tells a file from a registered name. Here, above the laws and the parser, so that neither
imports the other's loader (docs/security.md).
"""

from __future__ import annotations

import pathlib

from .cidr import define_cidr_law
from .direct import define_direct_law
from .expressions import placeholder_table, pressure_symbol
from .registry import check_law_name
from .declarative import LAW_SYMBOLS, _KEYS, _constants, _kind, _read_toml, is_declarative_law, parse_expression
from .material import Material
from ..validation import input_file

__all__ = ["is_file_law", "load_law_file", "load_declarative_law"]


def is_file_law(spec) -> bool:
    """True if `spec` names a law file (Python ``*.py`` or declarative ``*.toml``) rather than a registered law."""
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

    table = placeholder_table()
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


def load_declarative_law(path) -> type:
    """The law class of a declarative law file (its format: :mod:`.declarative`); nothing in it is run.

    Registered under its ``name`` (default: the file's stem), which may not be a built-in law's.
    """
    try:
        return _declared_law(path)
    except ValueError as err:
        text = str(err)
        raise ValueError(text if str(path) in text else f"law file {str(path)!r}: {text}") from None


def _declared_law(path) -> type:
    import sympy as sp

    from . import symbols as s

    path = pathlib.Path(path)
    where = f"law file {str(path)!r}"
    data, text = _read_toml(path)
    kind = _kind(data, where)
    material = data.get("material")
    if material is not None and not isinstance(material, dict):
        raise ValueError(f"{where}: [material] must be a table of Material arguments")
    material = Material(**material) if material else None
    parameters = (material or Material()).parameter_names()
    law_symbols = LAW_SYMBOLS["cidr" if kind == "cidr" else "direct"]
    table = {"p": pressure_symbol(), "I": s.I, "phi": s.phi, "div_u": s.div_u, "norm_S": s.norm_S,
             "M": s.M, "Psi": s.Psi}
    names = {n: table[n] for n in law_symbols}
    names.update({n: s.material_symbol(n) for n in parameters})
    names["pi"] = sp.pi
    names.update(_constants(data, where, set(names)))
    exprs = {key: parse_expression(data[key], names, f"{where}: {key}") for key in _KEYS[kind]}
    name, label = data.get("name", path.stem), data.get("label")
    for key, value in (("name", name), ("label", label)):
        if value is not None and not isinstance(value, str):
            raise ValueError(f"{where}: `{key}` must be a string; got {value!r}")
    check_law_name(name)
    key = f"declarative {name}\n{text}"
    if kind == "cidr":
        return define_cidr_law(name, exprs["yield_function"], exprs["dilatancy_function"], label=label,
                               material=material, key=key,
                               equation_of_state=data.get("equation_of_state", "auto"))
    if "equation_of_state" in data:
        raise ValueError(f"{where}: `equation_of_state` applies to a CIDR law (yield_function, dilatancy_function)")
    shear = exprs["shear_stress"] if kind == "direct" else exprs["c"] * s.norm_S
    return define_direct_law(name, exprs["pressure"], shear, label=label, material=material, key=key)
