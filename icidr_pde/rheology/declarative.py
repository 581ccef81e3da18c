"""Declarative law files (``*.toml``) and the safe parser of law expressions: data, never code.

A Python law file (:func:`~.law_files.load_law_file`) is a program: loading it runs it, with every
right of the user. A declarative law file is for sharing laws: a TOML table whose
expressions are parsed by :func:`parse_expression`, a whitelist over Python's :mod:`ast`
(no ``eval``, no ``sympify`` of text):

* operators ``+ - * / **`` and unary ``-``/``+``, parentheses;
* numbers (int or float literals, finite; a float is read as the exact decimal it spells);
* the law's symbols (:mod:`.symbols`): ``p, I, phi, M, Psi`` for a CIDR law (Y, f) (4.1)-(4.2),
  ``phi, div_u, norm_S, M, Psi`` for a law given as p and ||tau|| (or c = ||tau||/||S||),
  the material's parameters by name (``mu_s, phi_c, ...``), the file's own ``[parameters]``
  and ``pi``;
* the functions of :data:`FUNCTIONS` (``sqrt, exp, log, tanh, Abs, Max, Min`` ...: those the
  numba, numpy and C printers of :mod:`.codegen` and :mod:`.ccode` all print).

Anything else (a name, an attribute, a call of anything else, a comparison, a subscript, a
string, ...) is refused by a one-line error naming the file, the key, the expression and the
offending token. The format (TOML: comments carry a law's derivation and sources; ``tomllib``
is in the standard library from Python 3.11, ``tomli``, the same parser, below)::

    name = "half-rate-toml"           # not a built-in name (see `law list`)
    label = "half of iCIDR's rate dependence"
    yield_function = "M * p * (k * I / Psi + 1 - k)"                       # Y of (4.1)
    dilatancy_function = "M * (k * I / (4 * Psi) + 1 - k - Psi * (1 - 3 * k / 4) / I)"  # f of (4.2)
    # or: pressure = "..." with shear_stress = "..." (||tau||) or c = "..." (tau = c S)
    equation_of_state = "auto"        # optional, CIDR laws: "auto" or "scalar"
    [parameters]                      # optional: constants of the law
    k = 0.5
    [material]                        # optional: Material arguments (Table 1 by default)
    mu_s = 0.25
"""

from __future__ import annotations

import ast
import math
import pathlib
import sys

from ..validation import input_file

__all__ = ["FUNCTIONS", "parse_expression", "is_declarative_law", "DECLARATIVE_SUFFIXES"]

DECLARATIVE_SUFFIXES = (".toml",)

#: function name -> (sympy attribute, least and most number of arguments)
FUNCTIONS = {
    "sqrt": ("sqrt", 1, 1), "exp": ("exp", 1, 1), "log": ("log", 1, 1), "tanh": ("tanh", 1, 1),
    "sinh": ("sinh", 1, 1), "cosh": ("cosh", 1, 1), "atan": ("atan", 1, 1),
    "Abs": ("Abs", 1, 1), "abs": ("Abs", 1, 1), "Max": ("Max", 2, 16), "max": ("Max", 2, 16),
    "Min": ("Min", 2, 16), "min": ("Min", 2, 16),
}
#: symbols of each kind of law (the arguments of its functions, :mod:`.symbols`)
LAW_SYMBOLS = {"cidr": ("p", "I", "phi", "M", "Psi"), "direct": ("phi", "div_u", "norm_S", "M", "Psi")}
_KEYS = {"cidr": ("yield_function", "dilatancy_function"), "direct": ("pressure", "shear_stress"),
         "direct-c": ("pressure", "c")}
_OTHER_KEYS = ("name", "label", "equation_of_state", "parameters", "material")
MAX_LENGTH = 10_000          # characters of one expression
MAX_EXPONENT = 64            # |n| of a number raised to a number (sympy evaluates it exactly)
#: bits of the numerator and of the denominator of any number a formula builds: a float64 kernel
#: holds nothing beyond 2^1024 (nor a nonzero below 2^-1074), and a chain of powers within
#: MAX_EXPONENT, ((2**64)**64)**64..., multiplies the digits by 64 at each level
MAX_NUMBER_BITS = 1100
MAX_FILE_BYTES = 1 << 20     # a law is a few formulas
#: magnitudes of the nonzero constants a double holds (normal numbers): the kernels' arithmetic
DOUBLE_RANGE = (sys.float_info.min, sys.float_info.max)


class _Refused(ValueError):
    def __init__(self, token: str, why: str):
        self.token, self.why = token, why
        super().__init__(why)


def parse_expression(text: str, names: dict, where: str = "expression"):
    """The sympy expression of `text`, a formula in the names of `names` (name -> sympy object).

    Only the operators, numbers, names and :data:`FUNCTIONS` of the module docstring are
    accepted; anything else raises ValueError naming `where`, the expression and the token.
    """
    import sympy as sp

    if not isinstance(text, str):
        raise ValueError(f"{where}: must be a string (a formula); got {type(text).__name__} {text!r}")
    shown = text if len(text) <= 80 else text[:77] + "..."
    if len(text) > MAX_LENGTH:
        raise ValueError(f"{where}: expression {shown!r} is longer than {MAX_LENGTH} characters")
    try:
        expr = _build(text.strip(), names, sp)
    except _Refused as err:
        allowed = ", ".join(sorted(names))
        raise ValueError(f"{where}: expression {shown!r}: {err.token!r} is not allowed ({err.why}); "
                         f"names: {allowed}; functions: {', '.join(FUNCTIONS)}; operators + - * / **") from None
    except SyntaxError as err:
        raise ValueError(f"{where}: expression {shown!r} is not a formula ({err.msg}"
                         f"{'' if err.offset is None else f' at character {err.offset}'})") from None
    except (RecursionError, MemoryError):
        raise ValueError(f"{where}: expression {shown!r} is nested too deeply") from None
    if expr.has(sp.nan, sp.zoo, sp.oo, -sp.oo):
        raise ValueError(f"{where}: expression {shown!r} is not finite (it simplifies to contain "
                         f"{next(str(a) for a in (sp.nan, sp.zoo, sp.oo, -sp.oo) if expr.has(a))})")
    for number in expr.atoms(sp.Number):  # the kernels compute in doubles: 1e308*1e308 is 1e616 exactly here
        if not (number == 0 or DOUBLE_RANGE[0] <= abs(number) <= DOUBLE_RANGE[1]):
            raise ValueError(f"{where}: expression {shown!r} holds the constant {sp.Float(number, 3)}, outside "
                             f"the range of a double, [{DOUBLE_RANGE[0]:.3g}, {DOUBLE_RANGE[1]:.3g}] in magnitude")
    return expr


def _build(text: str, names: dict, sp):
    """The sympy expression of the formula `text` (stripped) through :class:`_Builder`."""
    try:
        tree = ast.parse(text, mode="eval")
    except RecursionError:
        # CPython refuses an AST deeper than a multiple of the recursion limit, and a flat sum is
        # a tree as deep as it has terms: its terms are parsed one by one (a deep term still fails)
        terms = _top_level_terms(text)
        if len(terms) < 2:
            raise
        return sp.Add(*(sign * _build(term, names, sp) for sign, term in terms))
    return _Builder(text, names, sp).visit(tree.body)


def _top_level_terms(text: str) -> list[tuple[int, str]]:
    """(sign, text) of the terms of `text` split at its binary + and - outside brackets."""
    import io
    import tokenize

    starts = [0]  # offset of each line of `text`
    for line in text.splitlines(keepends=True):
        starts.append(starts[-1] + len(line))
    terms, depth, begin, sign, previous = [], 0, 0, 1, None
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.OP and tok.string in "([{":
            depth += 1
        elif tok.type == tokenize.OP and tok.string in ")]}":
            depth -= 1
        elif (tok.type == tokenize.OP and tok.string in "+-" and depth == 0 and previous is not None
              and (previous.type in (tokenize.NAME, tokenize.NUMBER) or previous.string in ")]}")):
            at = starts[tok.start[0] - 1] + tok.start[1]  # a binary + or -: a term ends here
            terms.append((sign, text[begin:at].strip()))
            begin, sign = at + 1, 1 if tok.string == "+" else -1
        if tok.type not in (tokenize.NL, tokenize.NEWLINE, tokenize.COMMENT, tokenize.INDENT,
                            tokenize.DEDENT, tokenize.ENDMARKER):
            previous = tok
    terms.append((sign, text[begin:].strip()))
    return terms


class _Builder:
    """sympy from a whitelisted ast (one method per allowed node)."""

    BINARY = {ast.Add: "__add__", ast.Sub: "__sub__", ast.Mult: "__mul__", ast.Div: "__truediv__",
              ast.Pow: "__pow__"}

    def __init__(self, text, names, sp):
        self.text, self.names, self.sp = text, names, sp
        self.built = {}  # id of a link of a chain -> its expression, built before the link above it

    def token(self, node) -> str:
        return ast.get_source_segment(self.text.strip(), node) or type(node).__name__

    def visit(self, node):
        built = self.built.pop(id(node), None)
        if built is not None:
            return built
        if isinstance(node, ast.BinOp) and isinstance(node.left, ast.BinOp):
            # a flat sum or product of n terms is a left-nested chain n deep: built from its
            # innermost link outwards, each link's left operand is already built (no recursion)
            chain = [node]
            while isinstance(chain[-1].left, ast.BinOp):
                chain.append(chain[-1].left)
            for link in reversed(chain[1:]):
                self.built[id(link)] = self.visit_BinOp(link)
            return self.visit_BinOp(node)
        method = getattr(self, f"visit_{type(node).__name__}", None)
        if method is None:
            raise _Refused(self.token(node), f"{type(node).__name__.lower()} is not part of a formula")
        return method(node)

    def visit_BinOp(self, node):
        op = self.BINARY.get(type(node.op))
        if op is None:
            raise _Refused(self.token(node), f"operator {type(node.op).__name__} is not allowed")
        left, right = self.visit(node.left), self.visit(node.right)
        if op == "__pow__" and left.is_Number and right.is_Number:
            if abs(right) > MAX_EXPONENT:
                raise _Refused(self.token(node), f"a number to a power beyond +-{MAX_EXPONENT}")
            if left.is_Rational and _bits(left) * abs(float(right)) > MAX_NUMBER_BITS:  # before sympy builds it
                raise _Refused(self.token(node), self.TOO_LARGE)
        if op == "__truediv__" and right == 0:
            raise _Refused(self.token(node), "division by zero")
        return self.checked(node, getattr(left, op)(right))

    TOO_LARGE = (f"a number beyond {MAX_NUMBER_BITS} bits in its numerator or denominator "
                 f"(outside the range of a double: no float64 kernel holds it)")

    def checked(self, node, expr):
        """`expr`, built from the formula at `node`, unless it is a number out of every float's
        range (operands within the bound make it at most twice their size: checking each result
        bounds them all) or complex (sqrt or log of a negative number, a negative number to a
        fractional power: sympy's I, which no kernel evaluates and whose dropped imaginary part
        would change the law)."""
        if expr.is_Rational and _bits(expr) > MAX_NUMBER_BITS:
            raise _Refused(self.token(node), self.TOO_LARGE)
        makes_roots = isinstance(node, ast.Call) or isinstance(getattr(node, "op", None), ast.Pow)
        if makes_roots and _complex(expr, self.sp):  # sums and products of real numbers are real
            raise _Refused(self.token(node), "it is a complex number (the root or logarithm of a negative "
                                             "number, or a negative number to a fractional power)")
        return expr

    def visit_UnaryOp(self, node):
        if isinstance(node.op, ast.USub):
            return self.checked(node, -self.visit(node.operand))
        if isinstance(node.op, ast.UAdd):
            return self.visit(node.operand)
        raise _Refused(self.token(node), f"operator {type(node.op).__name__} is not allowed")

    def visit_Constant(self, node):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Refused(self.token(node), f"a {type(value).__name__} constant is not a number")
        if isinstance(value, int):
            if abs(value) > 10**300:
                raise _Refused(self.token(node), "an integer beyond 1e300")
            return self.sp.Integer(value)
        if not math.isfinite(value):
            raise _Refused(self.token(node), "a number must be finite")
        return self.sp.Rational(repr(value))

    def visit_Name(self, node):
        if node.id not in self.names:
            raise _Refused(node.id, "unknown name")
        return self.names[node.id]

    def visit_Attribute(self, node):
        self.visit(node.value)             # the innermost token refused is the one named
        raise _Refused(self.token(node), "attribute access is not part of a formula")

    def visit_Call(self, node):
        if not isinstance(node.func, ast.Name):
            self.visit(node.func)          # refuses the attribute, lambda, ... that is called
            raise _Refused(self.token(node.func), "only the functions below can be called")
        if node.func.id not in FUNCTIONS:
            raise _Refused(node.func.id, "not one of the functions")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise _Refused(self.token(node), "functions take plain arguments only")
        attr, lo, hi = FUNCTIONS[node.func.id]
        if not lo <= len(node.args) <= hi:
            raise _Refused(self.token(node), f"{node.func.id} takes {lo if lo == hi else f'{lo} to {hi}'} "
                                             f"argument(s), got {len(node.args)}")
        return self.checked(node, getattr(self.sp, attr)(*(self.visit(a) for a in node.args)))


def _complex(expr, sp) -> bool:
    """Whether `expr` holds sympy's I or a power of a negative number that is not real, e.g.
    (-1)**(1/3) (sympy's principal root)."""
    return expr.has(sp.I) or any(power.base.is_number and power.base.is_extended_negative
                                 and power.is_extended_real is False for power in expr.atoms(sp.Pow))


def _bits(number) -> int:
    """Bits of the larger of a sympy Rational's numerator and denominator."""
    return max(abs(int(number.p)).bit_length(), int(number.q).bit_length())


def is_declarative_law(spec) -> bool:
    """True if `spec` names a declarative law file (:data:`DECLARATIVE_SUFFIXES`)."""
    return isinstance(spec, (str, pathlib.Path)) and str(spec).endswith(DECLARATIVE_SUFFIXES)


def _read_toml(path: pathlib.Path) -> tuple[dict, str]:
    """(the table, the text) of the law file `path`, a regular file."""
    try:
        import tomllib
    except ModuleNotFoundError:   # Python < 3.11: the same parser, packaged (a dependency there)
        import tomli as tomllib
    input_file("rheology", path)
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ValueError(f"law file {str(path)!r} has {size} bytes; a law file has at most {MAX_FILE_BYTES}")
    try:
        text = path.read_text()
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as err:
        raise ValueError(f"law file {str(path)!r} is not valid TOML: {err}") from None
    except UnicodeDecodeError as err:
        raise ValueError(f"law file {str(path)!r} is not UTF-8 text: {err.reason}") from None
    except OSError as err:
        raise ValueError(f"law file {str(path)!r} cannot be read: {err.strerror or err}") from None
    except RecursionError:  # tomllib's parser recurses into nested arrays and tables
        raise ValueError(f"law file {str(path)!r} is nested too deeply to be a law") from None


def _kind(data: dict, where: str) -> str:
    kinds = [k for k, keys in _KEYS.items() if all(key in data for key in keys)]
    if len(kinds) != 1:
        raise ValueError(f"{where} must define yield_function and dilatancy_function (a CIDR law), or pressure "
                         "and shear_stress, or pressure and c (a law given as p and tau = c S), exactly one of these")
    known = set(_KEYS[kinds[0]]) | set(_OTHER_KEYS)
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"{where}: unknown key(s) {unknown} for this kind of law; valid: {sorted(known)}")
    return kinds[0]


def _constants(data: dict, where: str, taken: set) -> dict:
    """The file's [parameters]: name -> exact rational of a finite number."""
    import sympy as sp

    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise ValueError(f"{where}: [parameters] must be a table of name = number")
    out = {}
    for key, value in table.items():
        if not key.isidentifier() or key in taken or key in FUNCTIONS:
            raise ValueError(f"{where}: parameter name {key!r} must be an identifier that is not a law symbol, "
                             f"a material parameter or a function ({', '.join(sorted(taken))})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"{where}: parameter `{key}` must be a finite number; got {value!r}")
        out[key] = sp.Rational(repr(value)) if isinstance(value, float) else sp.Integer(value)
    return out
