"""Numeric kernels generated from the sympy definition of a law, compiled once per installation.

The sympy expression is the definition (:meth:`Rheology.law`, the laws of
:mod:`.laws`); this module turns it into Python source, writes that source into a cache
directory and imports it, so that numba can cache the compiled code on disk.

Why source files (measured on this project): numba's on-disk cache (``cache=True``)
works only for module-level functions of a real file. A closure recompiles in every
process, and a numba dispatcher passed as an argument to a cached function gets a new
cache index entry in every process. What does work is a module-level
``@njit(cache=True)`` function that calls other jitted functions as module globals.

The mechanism:

1. **Law modules** (:func:`law_kernels`). For a rheology (with its material's friction and
   dilatancy law classes) and a kinematics adapter (:mod:`.kinematics`), the outputs
   (e.g. p, tau_xz, tau_zz) and their derivatives by (phi, rates...) are reduced with
   ``sympy.cse`` and printed twice: as scalar numba functions ``stress`` and
   ``stress_jacobian`` (``@njit(cache=True)``, Piecewise as ``if/else``) with array loops
   ``stress_array``/``stress_jacobian_array``, and as plain numpy functions
   ``stress_numpy``/``stress_jacobian_numpy`` (no compilation). Material parameters are
   arguments (``params = material.params``), so one module serves every parameter value.
   Derivatives that are singular where a norm vanishes (x**(-1/2) with x = 0, e.g.
   d||S||/du_z at u_z = w_z = 0) are evaluated as 0 there: the stresses are Lipschitz but
   not differentiable at that point, and 0 is the mean of the one-sided slopes.
2. **Composite modules** (:func:`compose`). A loop kernel (a finite-volume or Chebyshev
   right-hand side, later a 2-D one) is a *template*: Python source of a module that
   contains the line ``import __law__ as law`` and calls ``law.stress(...)`` etc. inside
   ``@njit(cache=True)`` functions. :func:`compose` replaces ``__law__`` by the name of a
   law module and writes the result as a new file, so the law is a module global of the
   loop kernel and every (template, law) pair has its own file and its own cache entries.
   Any template combines with any law; sizes, grids and parameters are arguments, so a new
   N or new parameter values compile nothing.
3. **Where and keyed by what.** Files go to the kernel cache (:mod:`icidr_pde.kernel_cache`:
   the folder, its trust checks, names, verification and pruning), never into site-packages;
   numba's cache files of their functions go beside them. A module's name is a hash of
   everything its text is generated from: the source of the module defining the rheology,
   of :mod:`.laws`, :mod:`.kinematics`, this module and the template, sympy's version. It
   is looked up before any sympy work, so a second process imports the cached module and
   loads numba's cached machine code without importing sympy. The file is checked against
   the hash of its bytes in its name before it runs; files are written once and never
   rewritten. While the first call compiles, :func:`first_call` says so on stderr
   ("compiling kernels ... (once per installation)"); a marker file in the cache records
   that it has been compiled.
"""

from __future__ import annotations

import importlib.util
import inspect
import pathlib
import sys
import threading
import time

from .. import kernel_cache

__all__ = ["law_kernels", "law_expressions", "material_functions", "compose", "generated_source", "first_call"]

_MODULES: dict[str, object] = {}  # module name -> module
_BY_DEFINITION: dict[tuple, object] = {}  # (classes the module is generated from) -> module
_LOCK = threading.RLock()  # re-entrant: generating a law's kernels may load its material's functions


_digest = kernel_cache.digest


def _module_source(module_name: str) -> str:
    """Text of a module's file, found without importing it (sympy stays unimported)."""
    return pathlib.Path(importlib.util.find_spec(module_name).origin).read_text()


_sympy_version = kernel_cache.sympy_version


def _generator_key() -> str:
    return "\n".join([_sympy_version()] + [_module_source(m) for m in (
        __name__, f"{__package__}.laws", f"{__package__}.kinematics", f"{__package__}.material",
        f"{__package__}.base", f"{__package__}.symbols")])


def _load(kind: str, key: str, make_source) -> object:
    """Import the generated module for `key`, writing it with `make_source()` if missing.

    The module runs from the bytes :func:`icidr_pde.kernel_cache.read` verified (no bytecode file
    is read or written), under its stem as module name."""
    name = kernel_cache.stem(kind, _digest(key))
    with _LOCK:
        if name in _MODULES:
            return _MODULES[name]
        found = kernel_cache.read(name, ".py")
        if found is None:
            data = make_source().encode()
            found = kernel_cache.store(name, ".py", data), data
        path, data = found
        kernel_cache.numba_setup()
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            exec(compile(data, str(path), "exec"), module.__dict__)
        except Exception:
            del sys.modules[name]
            raise
        _MODULES[name] = module
        return module


# --- printing sympy as Python ---------------------------------------------------------


def _printers():
    import sympy as sp
    from sympy.printing.numpy import NumPyPrinter
    from sympy.printing.pycode import PythonCodePrinter

    class Scalar(PythonCodePrinter):
        def _print_Pow(self, expr, rational=False):
            # numba raises ZeroDivisionError for 0.0**(-k); 1.0/0.0**k follows error_model
            if expr.exp.is_Integer and expr.exp.is_negative:
                return f"(1.0/{self.parenthesize(expr.base, 60)}**{int(-expr.exp)})"
            return super()._print_Pow(expr, rational=rational)

        def _print_Piecewise(self, expr):
            # an if/else expression evaluates only the branch taken
            return _nested(self, expr, "(({e}) if ({c}) else ({rest}))")

    class Array(NumPyPrinter):
        def _print_Piecewise(self, expr):
            return _nested(self, expr, "numpy.where({c}, {e}, {rest})")

        # nested binary calls: sympy's own form, functools.reduce, needs an import the header lacks
        def _print_Max(self, expr):
            return _folded(self, expr, "numpy.maximum")

        def _print_Min(self, expr):
            return _folded(self, expr, "numpy.minimum")

    def _nested(printer, expr, form):
        *pairs, (last, cond) = expr.args
        if cond != sp.true:
            raise ValueError("a Piecewise needs a final (expr, True) branch")
        out = printer._print(last)
        for e, c in reversed(pairs):
            out = form.format(e=printer._print(e), c=printer._print(c), rest=out)
        return out

    def _folded(printer, expr, function):
        out = printer._print(expr.args[-1])
        for arg in reversed(expr.args[:-1]):
            out = f"{function}({printer._print(arg)}, {out})"
        return out

    return (Scalar(dict(fully_qualified_modules=True, user_functions={"rsqrt0": "_rsqrt0"})),
            Array(dict(fully_qualified_modules=True, user_functions={"rsqrt0": "_rsqrt0_np"})))


def _safe_powers(expr):
    """x**(-k/2) -> rsqrt0(x)**k, where rsqrt0(x) = 1/sqrt(x) for x > 0 and 0 otherwise."""
    import sympy as sp

    rsqrt0 = sp.Function("rsqrt0")
    return expr.replace(
        lambda e: e.is_Pow and e.exp.is_Rational and e.exp.is_negative and e.exp.q == 2,
        lambda e: rsqrt0(e.base) ** int(-2 * e.exp))


def _body(exprs, printer, indent="    ") -> tuple[list[str], list[str]]:
    """Lines assigning common subexpressions, and the printed outputs."""
    import sympy as sp

    exprs = [_safe_powers(sp.sympify(e)) for e in exprs]
    assignments, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_t"))
    lines = [f"{indent}{printer.doprint(s)} = {printer.doprint(e)}" for s, e in assignments]
    return lines, [printer.doprint(e) for e in reduced]


_HEADER = '''"""Generated by icidr_pde.rheology.codegen from {what}; do not edit (regenerated on change)."""
import math

import numpy
from numba import njit

_OPTIONS = dict(cache=True, error_model="numpy")


@njit(**_OPTIONS)
def _rsqrt0(x):
    return 1.0 / math.sqrt(x) if x > 0.0 else 0.0


def _rsqrt0_np(x):
    positive = x > 0
    return numpy.where(positive, 1.0 / numpy.sqrt(numpy.where(positive, x, 1.0)), 0.0)
'''


def _scalar_function(name, args, param_names, exprs, printer, pre="") -> str:
    lines, outs = _body(exprs, printer)
    unpack = f"    {', '.join(param_names)}, = params\n" if param_names else ""
    return (f"\n\n@njit(**_OPTIONS)\ndef {name}({', '.join(args)}, params):\n{unpack}{pre}"
            + "\n".join(lines) + ("\n" if lines else "") + f"    return ({', '.join(outs)},)\n")


def _array_loop(name, point, args, n_out) -> str:
    outs = [f"_o{k}" for k in range(n_out)]
    alloc = "".join(f"    {o} = numpy.empty({args[0]}.shape[0])\n" for o in outs)
    indexed = ", ".join(f"{a}[i]" for a in args)
    return (f"\n\n@njit(**_OPTIONS)\ndef {name}({', '.join(args)}, params):\n{alloc}"
            f"    for i in range({args[0]}.shape[0]):\n"
            f"        {', '.join(o + '[i]' for o in outs)}, = {point}({indexed}, params)\n"
            f"    return ({', '.join(outs)},)\n")


def _numpy_function(name, args, param_names, exprs, printer, single=False, pre="") -> str:
    lines, outs = _body(exprs, printer)
    unpack = f"    {', '.join(param_names)}, = params\n" if param_names else ""
    zero = f"    _zero = 0.0 * ({' + '.join(args)})\n"
    return (f"\n\ndef {name}({', '.join(args)}, params):\n{unpack}{zero}"
            "    with numpy.errstate(divide='ignore', invalid='ignore'):\n" + pre
            + "".join(f"    {line}\n" for line in lines)
            + (f"        return {outs[0]} + _zero\n" if single else
               f"        return ({', '.join(f'{o} + _zero' for o in outs)},)\n"))


def _python_names(symbols: dict) -> dict:
    import sympy as sp

    return {sym: sp.Symbol(name, real=True) for name, sym in symbols.items()}


def law_expressions(rheology, kinematics):
    """The outputs of `rheology` for `kinematics` and their derivatives, as sympy expressions
    in plain real symbols: (args, parameter names, outputs, jacobian (output by output),
    symbol map). The one definition every printer (numba, numpy, C) starts from."""
    import sympy as sp

    from .symbols import phi

    rates = kinematics.rate_symbols()
    div, norm = kinematics.invariants(rates)
    p, c = rheology.symbolic_stress(phi, div, norm, symbolic=True, stable=True)
    outputs = [sp.sympify(e) for e in kinematics.stresses(p, c, rates)]
    material = rheology.material
    prm = material.values(symbolic=True)
    names = _python_names({"phi": phi, **{r: s for r, s in zip(kinematics.rates, rates)},
                           **{k: prm[k] for k in material.parameter_names()}})
    outputs = [e.xreplace(names) for e in outputs]
    args = ["phi", *kinematics.rates]
    arg_symbols = [sp.Symbol(a, real=True) for a in args]
    jac = [sp.diff(e, v) for e in outputs for v in arg_symbols]
    return args, list(material.parameter_names()), outputs, jac, names


def unprintable(err, language: str) -> str:
    """One line saying that a law uses a function sympy cannot print in `language` (`err`, sympy's)."""
    from .declarative import FUNCTIONS

    what = str(err).splitlines()[0] if str(err) else type(err).__name__
    return (f"its {language} kernels cannot be generated ({what}); the printers know "
            f"{', '.join(dict.fromkeys(f for f, *_ in FUNCTIONS.values()))}, powers and Piecewise")


def generated_source(rheology, kinematics) -> str:
    """Python source of the law module of `rheology` for `kinematics` (see the docstring)."""
    try:
        return _generated_source(rheology, kinematics)
    except NotImplementedError as err:   # sympy's PrintMethodNotImplementedError: a function it cannot print
        from .errors import LawError

        raise LawError(rheology.name, unprintable(err, "numba/numpy")) from None


def _generated_source(rheology, kinematics) -> str:
    args, pnames, outputs, jac, names = law_expressions(rheology, kinematics)
    material = rheology.material
    scalar, array = _printers()
    n_out = len(outputs)
    what = (f"rheology {rheology.name!r}, laws {material.friction.name!r}/{material.dilatancy.name!r}, "
            f"kinematics {kinematics.name!r}: outputs {kinematics.outputs}, params {tuple(pnames)}")
    solve, pre, pre_np = "", "", ""
    roots = _implicit_roots(outputs + jac)
    if roots:  # sqrt(p) by the scalar solve (.implicit): its derivatives are already in `jac`
        solve, pre, pre_np, outputs, jac = _implicit_parts(roots, outputs, jac, names, pnames, scalar, array)
    return "".join([
        _HEADER.format(what=what),
        f"\nOUTPUTS = {tuple(kinematics.outputs)!r}\nRATES = {tuple(kinematics.rates)!r}\n"
        f"PARAMETERS = {tuple(pnames)!r}\n", solve,
        _scalar_function("stress", args, pnames, outputs, scalar, pre),
        _scalar_function("stress_jacobian", args, pnames, jac, scalar, pre),
        _array_loop("stress_array", "stress", args, n_out),
        _array_loop("stress_jacobian_array", "stress_jacobian", args, n_out * len(args)),
        _numpy_function("stress_numpy", args, pnames, outputs, array, pre=pre_np),
        _numpy_function("stress_jacobian_numpy", args, pnames, jac, array, pre=pre_np),
    ])


def _implicit_roots(exprs) -> set:
    from .implicit import ImplicitRoot

    return set().union(*(e.atoms(ImplicitRoot) for e in exprs))


def _implicit_parts(roots, outputs, jac, names, pnames, scalar, array):
    """Source of the flow-rule residual and the scalar solve, the line computing sqrt(p) (numba and
    numpy) and the outputs with the root replaced by that value (see :mod:`.implicit`)."""
    import sympy as sp

    from .implicit import SCALAR_SOLVER

    if len(roots) != 1:
        raise ValueError(f"a law's kernels can hold one implicit sqrt(p); got {len(roots)}")
    (root,) = roots
    cls = type(root)
    q, F = cls.root_symbol, cls.residual
    placeholders = cls.arg_symbols[:5]                         # phi, div_u, norm_S, M, Psi
    own = {a: names.get(a, sp.Symbol(k, real=True)) for a, k in zip(cls.arg_symbols[5:], pnames)}
    rargs = ["q", "phi", "div_u", "norm_S", "M", "Psi"]
    plain = {q: sp.Symbol("q", real=True), **{s: sp.Symbol(n, real=True) for s, n in zip(placeholders, rargs[1:])},
             **own}
    F = F.xreplace(plain)
    Fq = sp.diff(F, plain[q])
    source = (_scalar_function("_flow_residual", rargs, pnames, [F, Fq], scalar) + SCALAR_SOLVER
              + _numpy_function("_flow_residual_numpy", rargs, pnames, [F, Fq], array)
              + "\n\ndef sqrt_pressure_numpy(phi, div_u, norm_S, M, Psi, params):\n"
                "    from icidr_pde.rheology.implicit import solve_increasing\n\n"
                "    return solve_increasing(_flow_residual_numpy, phi, div_u, norm_S, M, Psi, params)\n")
    call_s = ", ".join(scalar.doprint(_safe_powers(a)) for a in root.args[:5])
    call_a = ", ".join(array.doprint(_safe_powers(a)) for a in root.args[:5])
    pre = f"    _q = sqrt_pressure({call_s}, params)\n"
    pre_np = f"        _q = sqrt_pressure_numpy({call_a}, params)\n"
    qs = {root: sp.Symbol("_q", real=True)}
    return source, pre, pre_np, [e.xreplace(qs) for e in outputs], [e.xreplace(qs) for e in jac]


def law_kernels(rheology, kinematics):
    """The generated (and imported) law module of `rheology` for `kinematics`."""
    memo = (type(rheology), rheology.material.law_key(), type(kinematics))
    if memo not in _BY_DEFINITION:
        _BY_DEFINITION[memo] = _law_kernels(rheology, kinematics)
    return _BY_DEFINITION[memo]


def _law_kernels(rheology, kinematics):
    friction, dilatancy = rheology.material.law_key()
    key = "\n".join([_generator_key(), rheology.definition_key(), type(rheology).__qualname__,
                     friction.__qualname__, dilatancy.__qualname__, type(kinematics).__qualname__,
                     inspect.getsource(type(kinematics))])
    return _load("law", key, lambda: generated_source(rheology, kinematics))


def _material_source(material) -> str:
    from .symbols import I, phi

    prm = material.values(symbolic=True)
    pnames = list(material.parameter_names())
    names = _python_names({"I": I, "phi": phi, **{k: prm[k] for k in pnames}})
    _, array = _printers()
    parts = [_HEADER.format(what=f"laws {material.friction.name!r}/{material.dilatancy.name!r}")]
    for fname, arg, expr in (("mu", "I", material.symbolic_mu(I, True)),
                             ("Phi", "I", material.symbolic_Phi(I, True)),
                             ("Psi", "phi", material.symbolic_Psi(phi, True)),
                             ("M", "phi", material.symbolic_M(phi, True))):
        parts.append(_numpy_function(fname, [arg], pnames, [expr.xreplace(names)], array, single=True))
    return "".join(parts)


def material_functions(material):
    """Generated numpy module with mu(I, params), Phi(I, params), Psi(phi, params), M(phi, params)."""
    friction, dilatancy = memo = material.law_key()
    if memo not in _BY_DEFINITION:
        key = "\n".join([_generator_key(), friction.__qualname__, dilatancy.__qualname__])
        _BY_DEFINITION[memo] = _load("material", key, lambda: _material_source(material))
    return _BY_DEFINITION[memo]


def compose(template: str, law_module, name: str = "loops"):
    """Import `template` (module source containing ``import __law__ as law``) bound to `law_module`.

    Returns the module; its ``@njit(cache=True)`` functions compile once per installation
    for each (template, law) pair and are loaded from numba's cache afterwards.
    """
    if "import __law__ as law" not in template:
        raise ValueError("a kernel template must contain the line `import __law__ as law`")
    if not name.isidentifier():
        raise ValueError(f"`name` must be an identifier; got {name!r}")
    text = template.replace("import __law__ as law", f"import {law_module.__name__} as law")
    return _load(name, text, lambda: text)


def first_call(module, call, what: str):
    """Return call(); if `module`'s kernels were never compiled in this installation, say so
    on stderr while numba compiles them (a marker file in the kernel cache records it)."""
    if kernel_cache.read(module.__name__, ".compiled") is not None:
        return call()
    sys.stderr.write(f"icidr-pde: compiling kernels for {what} (once per installation) ...\n")
    sys.stderr.flush()
    start = time.perf_counter()
    out = call()
    kernel_cache.store(module.__name__, ".compiled", f"{time.perf_counter() - start:.3f} s\n".encode())
    sys.stderr.write(f"icidr-pde: kernels compiled in {time.perf_counter() - start:.1f} s\n")
    sys.stderr.flush()
    return out
