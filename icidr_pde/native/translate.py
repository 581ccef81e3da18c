"""C from a scheme's numba template: every scheme is written once, in Python.

The kernels of a discretization (``discretizations/templates/fd.py``, ``cheb.py``) are
written once, as ``@njit`` functions of a small subset of Python; numba compiles them for
the py-pde path (:func:`icidr_pde.rheology.codegen.compose`) and :func:`translate` prints
the same functions as C for the native engine, operation for operation and parenthesised
as Python parses them, so both forms compute the same numbers (gcc with
``-ffp-contract=off``, numba without fastmath: no fused multiply-adds in either).

The subset, what the templates use:

* parameters annotated with their numba types (``"float64[:, :]"``, ``"float64"``,
  ``"int64"``, ``"boolean"``); an array parameter ``a`` of d dimensions becomes
  ``double *a, long a_shape0, .., long a_shape{d-1}`` in C, row-major unless `storage`
  names a macro ``M(a, i, j)`` for it (a band or column-major matrix of the caller);
* local scalars (int where every value assigned is, else double), declared at the top;
  ``numpy.empty(shape)`` (``kernel_empty``, freed at the end by ``kernel_free``: the C driver
  defines them; no ``return`` of a value), a row ``a[k]`` of an
  array, a tuple of scalars as a small local array;
* ``a, b = x, y`` (where no x, y reads a or b), ``a, b, c = x.shape``;
* ``for .. in range(..)``, ``if``/``elif``/``else``, ``a if c else b``, ``continue``,
  ``break``, ``+= -= *=``, ``max``/``min`` of ints, ``x.shape[k]``;
* calls of the template's own functions (arrays passed with their shapes), of the law
  (``law.stress(..)`` and ``law.stress_jacobian(..)``: ``law_stress(.., out)`` of
  :mod:`icidr_pde.rheology.ccode`) and ``numpy.dot`` of a matrix with a vector or a matrix
  (``kernel_dot_mv``/``kernel_dot_mm``, which the C driver defines: BLAS where present).

Anything else is refused with a :class:`SyntaxError` naming the line.
"""

from __future__ import annotations

import ast

__all__ = ["translate"]

_OPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Mod: "%", ast.FloorDiv: "/"}
_CMP = {ast.Gt: ">", ast.GtE: ">=", ast.Lt: "<", ast.LtE: "<=", ast.Eq: "==", ast.NotEq: "!="}
_LAW = {"stress": "LAW_N_OUTPUTS", "stress_jacobian": "LAW_N_OUTPUTS * LAW_N_ARGS"}


def _annotation(arg: ast.arg) -> tuple[str, int]:
    """('double' | 'long' | 'int', ndim) of a parameter's numba type string."""
    node = arg.annotation
    text = node.value if isinstance(node, ast.Constant) else None
    if not isinstance(text, str):
        raise SyntaxError(f"line {arg.lineno}: parameters need a numba type string ({arg.arg!r})")
    base = text.split("[")[0].strip()
    ndim = text.count(":") if "[" in text else 0
    kind = {"float64": "double", "int64": "long", "boolean": "int"}.get(base)
    if kind is None:
        raise SyntaxError(f"line {node.lineno}: type {text!r} not in the subset")
    return kind, ndim


class _Function:
    """One template function printed as C (see the module docstring)."""

    def __init__(self, node: ast.FunctionDef, prefix: str, signatures: dict, storage: dict):
        self.node, self.prefix, self.signatures, self.storage = node, prefix, signatures, storage
        self.arrays: dict[str, int] = {}   # name -> ndim (parameters, locals, views)
        self.fixed: dict[str, str] = {}    # name -> length of a small local array (law outputs, tuples)
        self.scalars: dict[str, str] = {}  # name -> C type
        self.allocated: list[str] = []
        for arg in node.args.args:
            kind, ndim = _annotation(arg)
            if ndim:
                self.arrays[arg.arg] = ndim
            else:
                self.scalars[arg.arg] = kind
        self.params = set(self.arrays) | set(self.scalars)
        self.lines: list[str] = []

    # --- types --------------------------------------------------------------------------------

    def kind(self, e) -> str:
        """'long' or 'double' of a scalar expression."""
        if isinstance(e, ast.Constant):
            return "long" if isinstance(e.value, (bool, int)) else "double"
        if isinstance(e, ast.Name):
            if e.id not in self.scalars:
                raise SyntaxError(f"line {e.lineno}: {e.id!r} used before it is assigned")
            return "double" if self.scalars[e.id] == "double" else "long"
        if isinstance(e, ast.BinOp):
            if isinstance(e.op, ast.Div):
                return "double"
            return "long" if self.kind(e.left) == self.kind(e.right) == "long" else "double"
        if isinstance(e, ast.UnaryOp):
            return "long" if isinstance(e.op, ast.Not) else self.kind(e.operand)
        if isinstance(e, (ast.Compare, ast.BoolOp)):
            return "long"
        if isinstance(e, ast.IfExp):
            return "long" if self.kind(e.body) == self.kind(e.orelse) == "long" else "double"
        if isinstance(e, ast.Call) and isinstance(e.func, ast.Name) and e.func.id in ("max", "min"):
            return "long" if all(self.kind(a) == "long" for a in e.args) else "double"
        if isinstance(e, ast.Subscript):
            if isinstance(e.value, ast.Attribute) and e.value.attr == "shape":
                return "long"
            return "double"
        raise SyntaxError(f"line {e.lineno}: expression {ast.unparse(e)!r} not in the subset")

    def declare(self, name: str, kind: str, lineno: int) -> None:
        if name in self.arrays or name in self.fixed:
            raise SyntaxError(f"line {lineno}: {name!r} is an array and a scalar")
        old = self.scalars.get(name)
        if old is None:
            self.scalars[name] = kind
        elif old != kind and not (old == "double" and kind == "long"):
            raise SyntaxError(f"line {lineno}: {name!r} holds an int and a double (one type a name)")

    # --- expressions --------------------------------------------------------------------------

    def index(self, e: ast.Subscript) -> str:
        name = e.value.id
        idx = e.slice.elts if isinstance(e.slice, ast.Tuple) else [e.slice]
        if any(isinstance(i, ast.Slice) for i in idx):
            raise SyntaxError(f"line {e.lineno}: slices are not in the subset")
        parts = [self.expr(i) for i in idx]
        if name in self.fixed:
            return f"{name}[{parts[0]}]"
        ndim = self.arrays.get(name)
        if ndim is None:
            raise SyntaxError(f"line {e.lineno}: {name!r} is not an array")
        if len(parts) != ndim:
            raise SyntaxError(f"line {e.lineno}: {name!r} needs {ndim} indices")
        if name in self.storage:
            return f"{self.storage[name]}({name}, {', '.join(parts)})"
        flat = parts[0]
        for k, p in enumerate(parts[1:], 1):
            flat = f"({flat}) * {name}_shape{k} + ({p})"
        return f"{name}[{flat}]"

    def expr(self, e) -> str:
        if isinstance(e, ast.Constant):
            if isinstance(e.value, bool):
                return str(int(e.value))
            if isinstance(e.value, float):
                return repr(e.value)
            if isinstance(e.value, int):
                return str(e.value)
        if isinstance(e, ast.Name):
            return e.id
        if isinstance(e, ast.BinOp) and type(e.op) in _OPS:
            left, right = self.expr(e.left), self.expr(e.right)
            if isinstance(e.op, ast.Div) and self.kind(e.left) == self.kind(e.right) == "long":
                left = f"(double)({left})"
            if isinstance(e.op, (ast.FloorDiv, ast.Mod)) and "double" in (self.kind(e.left), self.kind(e.right)):
                raise SyntaxError(f"line {e.lineno}: // and % of doubles are not in the subset")
            return f"({left} {_OPS[type(e.op)]} {right})"
        if isinstance(e, ast.UnaryOp) and isinstance(e.op, (ast.USub, ast.Not)):
            return f"({'-' if isinstance(e.op, ast.USub) else '!'}{self.expr(e.operand)})"
        if isinstance(e, ast.Compare) and len(e.ops) == 1 and type(e.ops[0]) in _CMP:
            return f"({self.expr(e.left)} {_CMP[type(e.ops[0])]} {self.expr(e.comparators[0])})"
        if isinstance(e, ast.BoolOp):
            op = " && " if isinstance(e.op, ast.And) else " || "
            return "(" + op.join(self.expr(v) for v in e.values) + ")"
        if isinstance(e, ast.IfExp):
            return f"({self.expr(e.test)} ? {self.expr(e.body)} : {self.expr(e.orelse)})"
        if isinstance(e, ast.Call) and isinstance(e.func, ast.Name) and e.func.id in ("max", "min") \
                and len(e.args) == 2 and self.kind(e) == "long":
            a, b = (self.expr(x) for x in e.args)
            return f"(({a}) {'>' if e.func.id == 'max' else '<'} ({b}) ? ({a}) : ({b}))"
        if isinstance(e, ast.Subscript):
            if isinstance(e.value, ast.Attribute) and e.value.attr == "shape":
                return f"{e.value.value.id}_shape{e.slice.value}"
            return self.index(e)
        raise SyntaxError(f"line {e.lineno}: expression {ast.unparse(e)!r} not in the subset")

    def names(self, args, lineno) -> list[str]:
        """The names of array arguments (numpy.dot takes arrays by name only)."""
        if not all(isinstance(a, ast.Name) and a.id in self.arrays for a in args):
            raise SyntaxError(f"line {lineno}: numpy.dot takes arrays by name (a row: assign it first)")
        return [a.id for a in args]

    def arguments(self, args) -> str:
        out = []
        for a in args:
            if isinstance(a, ast.Name) and a.id in self.arrays:
                out += [a.id] + [f"{a.id}_shape{k}" for k in range(self.arrays[a.id])]
            elif isinstance(a, ast.Name) and a.id in self.fixed:
                out.append(a.id)
            else:
                out.append(self.expr(a))
        return ", ".join(out)

    # --- statements ---------------------------------------------------------------------------

    def emit(self, depth: int, text: str) -> None:
        self.lines.append("    " * depth + text)

    def block(self, body, depth: int) -> None:
        for s in body:
            self.statement(s, depth)

    def assign_call(self, target, call, depth, lineno) -> bool:
        """law.stress / law.stress_jacobian / numpy.empty / numpy.dot / a row; True if handled."""
        func = call.func
        if isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name):
            owner, attr = func.value.id, func.attr
            if owner == "law" and attr in _LAW:
                args = ", ".join(self.expr(a) for a in call.args)
                if isinstance(target, ast.Tuple):
                    names = [t.id for t in target.elts]
                    for n in names:
                        self.declare(n, "double", lineno)
                    self.emit(depth, "{")
                    self.emit(depth + 1, f"double _out[{_LAW[attr]}];")
                    self.emit(depth + 1, f"law_{attr}({args}, _out);")
                    for k, n in enumerate(names):
                        self.emit(depth + 1, f"{n} = _out[{k}];")
                    self.emit(depth, "}")
                else:
                    self.fixed.setdefault(target.id, _LAW[attr])
                    self.emit(depth, f"law_{attr}({args}, {target.id});")
                return True
            if owner == "numpy" and attr == "empty":
                shape = call.args[0].elts if isinstance(call.args[0], ast.Tuple) else [call.args[0]]
                name = target.id
                if name in self.arrays:
                    raise SyntaxError(f"line {lineno}: array {name!r} allocated twice")
                self.arrays[name] = len(shape)
                size = []
                for k, s in enumerate(shape):
                    self.scalars[f"{name}_shape{k}"] = "long"
                    self.emit(depth, f"{name}_shape{k} = {self.expr(s)};")
                    size.append(f"{name}_shape{k}")
                self.emit(depth, f"{name} = kernel_empty(sizeof(double) * {' * '.join(size)});")
                self.allocated.append(name)
                return True
            if owner == "numpy" and attr == "dot":
                a, b = self.names(call.args, lineno)
                name = target.id
                nb = self.arrays[b]
                self.assign_call(target, ast.Call(
                    func=ast.Attribute(value=ast.Name("numpy"), attr="empty"),
                    args=[ast.Tuple(elts=[ast.parse(f"{a}.shape[0]").body[0].value]
                                    + ([ast.parse(f"{b}.shape[1]").body[0].value] if nb == 2 else []))]),
                    depth, lineno)
                if nb == 1:
                    self.emit(depth, f"kernel_dot_mv({a}, {a}_shape0, {a}_shape1, {b}, {name});")
                else:
                    self.emit(depth, f"kernel_dot_mm({a}, {a}_shape0, {a}_shape1, {b}, {b}_shape1, {name});")
                return True
        return False

    def statement(self, s, depth: int) -> None:
        if isinstance(s, ast.Expr):
            if isinstance(s.value, ast.Constant) and isinstance(s.value.value, str):
                return  # a docstring
            call = s.value
            if isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute) and call.func.attr == "dot" \
                    and len(call.args) == 3:  # numpy.dot(a, b, out)
                a, b, out = self.names(call.args, s.lineno)
                if self.arrays[b] == 1:
                    self.emit(depth, f"kernel_dot_mv({a}, {a}_shape0, {a}_shape1, {b}, {out});")
                else:
                    self.emit(depth, f"kernel_dot_mm({a}, {a}_shape0, {a}_shape1, {b}, {b}_shape1, {out});")
                return
            if isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id in self.signatures:
                self.emit(depth, f"{self.prefix}{call.func.id}({self.arguments(call.args)});")
                return
        elif isinstance(s, ast.Assign) and len(s.targets) == 1:
            target, value = s.targets[0], s.value
            if isinstance(value, ast.Call) and self.assign_call(target, value, depth, s.lineno):
                return
            if isinstance(target, ast.Tuple) and isinstance(value, ast.Attribute) and value.attr == "shape" \
                    and isinstance(value.value, ast.Name) and value.value.id in self.arrays \
                    and len(target.elts) == self.arrays[value.value.id]:  # a, b, c = x.shape
                for k, t in enumerate(target.elts):
                    self.declare(t.id, "long", s.lineno)
                    self.emit(depth, f"{t.id} = {value.value.id}_shape{k};")
                return
            if isinstance(target, ast.Tuple) and isinstance(value, ast.Tuple) \
                    and len(target.elts) == len(value.elts) and all(isinstance(t, ast.Name) for t in target.elts):
                names = {t.id for t in target.elts}  # a, b = x, y: one at a time is the same where no y reads an a
                if any(isinstance(n, ast.Name) and n.id in names for v in value.elts for n in ast.walk(v)):
                    raise SyntaxError(f"line {s.lineno}: a tuple assignment that reads its own targets")
                for t, v in zip(target.elts, value.elts):
                    self.declare(t.id, self.kind(v), s.lineno)
                    self.emit(depth, f"{t.id} = {self.expr(v)};")
                return
            if isinstance(target, ast.Name) and isinstance(value, ast.Tuple):  # a small local array
                self.fixed[target.id] = str(len(value.elts))
                for k, v in enumerate(value.elts):
                    self.emit(depth, f"{target.id}[{k}] = {self.expr(v)};")
                return
            if isinstance(target, ast.Name) and isinstance(value, ast.Subscript) \
                    and isinstance(value.value, ast.Name) and not isinstance(value.slice, ast.Tuple) \
                    and self.arrays.get(value.value.id, 0) >= 2:
                src, ndim = value.value.id, self.arrays[value.value.id]  # a row view
                self.arrays[target.id] = ndim - 1
                stride = " * ".join(f"{src}_shape{k}" for k in range(1, ndim))
                self.emit(depth, f"{target.id} = {src} + ({self.expr(value.slice)}) * {stride};")
                for k in range(1, ndim):
                    self.scalars[f"{target.id}_shape{k - 1}"] = "long"
                    self.emit(depth, f"{target.id}_shape{k - 1} = {src}_shape{k};")
                return
            if isinstance(target, ast.Name) and isinstance(value, ast.IfExp) \
                    and isinstance(value.body, ast.Name) and value.body.id in self.fixed:
                self.fixed[target.id] = "pointer"  # one of two small arrays
                self.emit(depth, f"{target.id} = {self.expr(value)};")
                return
            if isinstance(target, ast.Name):
                self.declare(target.id, self.kind(value), s.lineno)
                self.emit(depth, f"{target.id} = {self.expr(value)};")
                return
            if isinstance(target, ast.Subscript):
                self.emit(depth, f"{self.index(target)} = {self.expr(value)};")
                return
        elif isinstance(s, ast.AugAssign) and type(s.op) in (ast.Add, ast.Sub, ast.Mult):
            target = self.index(s.target) if isinstance(s.target, ast.Subscript) else s.target.id
            if isinstance(s.target, ast.Name):
                self.declare(s.target.id, self.kind(ast.BinOp(s.target, s.op, s.value)), s.lineno)
            self.emit(depth, f"{target} {_OPS[type(s.op)]}= {self.expr(s.value)};")
            return
        elif isinstance(s, ast.For) and isinstance(s.target, ast.Name) and isinstance(s.iter, ast.Call) \
                and isinstance(s.iter.func, ast.Name) and s.iter.func.id == "range" and not s.orelse:
            args = s.iter.args
            lo, hi = (("0", self.expr(args[0])) if len(args) == 1 else (self.expr(args[0]), self.expr(args[1])))
            if len(args) > 2:
                raise SyntaxError(f"line {s.lineno}: range with a step is not in the subset")
            v = s.target.id
            self.declare(v, "long", s.lineno)
            self.emit(depth, f"for ({v} = {lo}; {v} < {hi}; {v}++) {{")
            self.block(s.body, depth + 1)
            self.emit(depth, "}")
            return
        elif isinstance(s, ast.If):
            self.emit(depth, f"if ({self.expr(s.test)}) {{")
            self.block(s.body, depth + 1)
            while len(s.orelse) == 1 and isinstance(s.orelse[0], ast.If):
                s = s.orelse[0]
                self.emit(depth, f"}} else if ({self.expr(s.test)}) {{")
                self.block(s.body, depth + 1)
            if s.orelse:
                self.emit(depth, "} else {")
                self.block(s.orelse, depth + 1)
            self.emit(depth, "}")
            return
        elif isinstance(s, ast.Continue):
            self.emit(depth, "continue;")
            return
        elif isinstance(s, ast.Break):
            self.emit(depth, "break;")
            return
        raise SyntaxError(f"line {s.lineno}: statement {ast.unparse(s)!r} not in the subset")

    def signature(self) -> str:
        parts = []
        for arg in self.node.args.args:
            kind, ndim = _annotation(arg)
            if ndim:
                parts += [f"double *{arg.arg}"] + [f"long {arg.arg}_shape{k}" for k in range(ndim)]
            else:
                parts.append(f"{kind} {arg.arg}")
        return f"static inline void {self.prefix}{self.node.name}({', '.join(parts)})"

    def source(self) -> str:
        self.block(self.node.body, 1)
        declared = []
        for name, kind in self.scalars.items():
            if name not in self.params:
                declared.append(f"    {kind} {name};")
        for name in self.arrays:
            if name not in self.params:
                declared.append(f"    double *{name};")
        for name, length in self.fixed.items():
            declared.append(f"    double *{name};" if length == "pointer" else f"    double {name}[{length}];")
        frees = [f"    kernel_free({name});" for name in self.allocated]
        doc = ast.get_docstring(self.node)
        comment = f"/* {' '.join(doc.split())} */\n" if doc else ""
        return "\n".join([comment + self.signature(), "{", *declared, *self.lines, *frees, "}"]) + "\n"


def translate(source: str, prefix: str, storage: dict | None = None, names=None) -> str:
    """C text of the ``@njit`` functions of the template `source` (see the module docstring),
    each named `prefix` + its name (those in `names` only, if given: the others may use what the
    subset has not, as a function that returns an array); `storage` maps an array parameter to the
    C macro ``M(name, i, j, ..)`` that addresses its elements (default: row-major)."""
    tree = ast.parse(source)
    functions = [n for n in tree.body if isinstance(n, ast.FunctionDef) and (names is None or n.name in names)]
    signatures = {f.name: f for f in functions}
    out = [f"/* Printed by icidr_pde.native.translate from the numba template of the scheme; do not edit. */\n"]
    prototypes = [_Function(f, prefix, signatures, storage or {}).signature() + ";" for f in functions]
    out.append("\n".join(prototypes) + "\n")
    for f in functions:
        out.append(_Function(f, prefix, signatures, storage or {}).source())
    return "\n".join(out)
