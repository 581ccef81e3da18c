"""Check records and the two ways an identity is established.

* ``exact``: ``sympy.simplify`` of (derived - claimed) is 0 (or a stated symbolic proof).
* ``numeric``: both sides evaluated with mpmath at 30 significant digits at random
  rational points agree to 1e-25 relative (used where simplify is too slow or
  cannot see through branch choices of square roots).
* ``fails``: neither; the derived (correct) expression is reported.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import sympy as sp

from .symbols import Mf, Psif

EXACT, NUMERIC, FAILS = "exact", "numeric", "fails"


@dataclass
class Check:
    """One verified claim of the paper."""

    equation: str
    claim: str
    status: str
    detail: str = ""
    corrected: str | None = None
    section: str = field(default="", compare=False)

    def to_json(self) -> dict:
        out = {"equation": self.equation, "status": self.status, "detail": self.detail}
        out["claim"] = self.claim
        if self.corrected is not None:
            out["corrected"] = self.corrected
        return out


def exact_zero(expr) -> bool:
    """True if sympy proves `expr` == 0 (simplify, then a radsimp/expand fallback)."""
    e = sp.simplify(expr)
    if e == 0:
        return True
    e2 = sp.simplify(sp.radsimp(sp.expand(e)))
    return e2 == 0


def random_points(symbols, n=6, seed=2019, positive=(), ranges=None):
    """Random rational sample points (dicts) for `symbols`.

    `ranges` maps a symbol to (lo, hi); default (-2, 2), or (1/10, 2) for symbols that
    are positive by assumption or listed in `positive`.
    """
    rng = random.Random(seed)
    ranges = ranges or {}
    pts = []
    for _ in range(n):
        pt = {}
        for s in symbols:
            lo, hi = ranges.get(s, (sp.Rational(1, 10), 2) if (s.is_positive or s in positive) else (-2, 2))
            k = rng.randint(1, 10**6)
            pt[s] = sp.Rational(lo) + (sp.Rational(hi) - sp.Rational(lo)) * sp.Rational(k, 10**6 + 1)
        pts.append(pt)
    return pts


def _instantiate_functions(expr):
    """Replace the generic M(.), Psi(.) by fixed smooth positive test functions.

    An identity that holds for arbitrary M and Psi must hold for these in particular.
    """
    x = sp.Dummy("x")
    expr = sp.sympify(expr)
    expr = expr.replace(Mf, sp.Lambda(x, (2 + sp.sin(x)) / 7)).replace(Psif, sp.Lambda(x, (3 + sp.cos(x)) / 5))
    return expr.doit()


def numeric_zero(expr, symbols=None, n=6, seed=2019, digits=30, ranges=None, scale=None) -> bool:
    """True if `expr` vanishes to 1e-25 relative at `n` random rational points (30 digits).

    `scale` is an expression giving the natural magnitude (defaults to 1 + |terms|).
    """
    expr = _instantiate_functions(expr)
    scale = _instantiate_functions(scale) if scale is not None else None
    symbols = sorted(expr.free_symbols, key=str) if symbols is None else symbols
    for pt in random_points(symbols, n=n, seed=seed, ranges=ranges):
        val = sp.N(expr.subs(pt), digits)
        ref = 1 + abs(sp.N((scale if scale is not None else 0).subs(pt) if scale is not None else 0, digits))
        if not val.is_number or abs(complex(val)) > 1e-25 * float(ref):
            return False
    return True


def compare(equation, claim, derived, printed, section="", ranges=None, scale=None, try_exact=True):
    """Compare a derived expression with the printed one; return a :class:`Check`."""
    diff = derived - printed
    if try_exact and exact_zero(diff):
        return Check(equation, claim, EXACT, "sympy.simplify(derived - printed) == 0", section=section)
    if numeric_zero(diff, ranges=ranges, scale=scale if scale is not None else abs(derived)):
        return Check(equation, claim, NUMERIC,
                     "derived and printed agree to 1e-25 at 6 random rational points (30 digits)",
                     section=section)
    return Check(equation, claim, FAILS,
                 "derived expression differs from the printed one",
                 corrected=sp.sstr(derived), section=section)
