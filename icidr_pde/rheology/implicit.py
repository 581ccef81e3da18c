"""The equation of state by a safeguarded scalar solve, for flow rules without a closed form.

A CIDR law's flow rule (4.2) with (2.9), div u = 2 f(p, I, phi) ||S|| with I = 2||S||/sqrt(p),
is one scalar equation for q = sqrt(p) at each state (phi, div u, ||S||). Where sympy finds
no usable closed-form root (:mod:`.cidr`), q is defined *implicitly* by the residual

    F(q) = div u - 2 ||S|| f(q^2, 2||S||/q, phi) = 0,

and this module supplies both halves of that definition, from the one sympy expression F:

* **symbolic**: :func:`implicit_root_class` makes a sympy Function ``sqrt_p_<law>(phi, div_u,
  norm_S, M, Psi, *parameters)`` whose derivatives are the implicit function theorem,
  dq/dx = -F_x/F_q at q = the root (:meth:`ImplicitRoot.fdiff`; sympy's ``idiff`` rule, applied
  to every argument). ``sp.diff`` of any expression containing it is then exact, so the
  kernels' Jacobians (:mod:`.codegen`) and the stability toolkit's symbols (A(xi), Gamma) come
  from the same F with no derivative written by hand; ``evalf`` solves F = 0 with mpmath at
  the working precision, and ``lambdify`` evaluates it with :func:`solve_increasing`;
* **numeric**: :func:`solve_increasing` (numpy, vectorised) and its scalar twin in
  :data:`SCALAR_SOLVER` (numba source, compiled into each generated law module with that law's
  residual as a module global) run the same bracketed Newton iteration.

**The iteration.** Condition (4.5) says df/dp < 0 at fixed ||S|| (the operator of (4.5),
d/dp - (I/2p) d/dI, is d/dp at fixed ||S||), so F is increasing in q: a bracket [lo, hi]
with F(lo) < 0 < F(hi) holds exactly one root. From q = 1 the bracket is grown by factors of
8 (at most 180 times, so q in [1e-154, 1e154]: p anywhere in the float range); then Newton
steps q - F/F_q are taken, each replaced by the geometric mean of the bracket when it leaves
the bracket or is not finite, the bracket shrinking with every residual sign. It stops when a
step or the bracket is below 4 eps q (round-off of q), after at most 200 iterations. Outcomes:

* F > 0 down to q = 1e-154: p is below the float range, returned as p = 0 (the zero-pressure
  set (4.13), e.g. ||S|| = 0 with div u >= 0);
* F < 0 up to q = 1e154, a non-finite residual, or no convergence: an error naming the
  state (phi, div u, ||S||) -- never a NaN. A law is refused before it runs if this happens
  on the sample of :func:`~.cidr.sample_states` (:meth:`~.cidr.CIDRLaw.admissibility`).

Where the residual is not finite at ||S|| = 0 (an unexpanded 2||S|| f gives 0 * inf even where
it has a finite limit), it is evaluated at ||S|| = 1e-150 (``NORM_S_FLOOR``) instead; the
workbench expands 2||S|| f first, so that iCIDR's, M||S||^2/(q Psi) - M Psi q/4, is finite there.
"""

from __future__ import annotations

import re

import numpy as np

__all__ = ["ImplicitRoot", "implicit_root_class", "solve_increasing", "SCALAR_SOLVER", "TOL", "MAX_ITER",
           "MAX_EXPAND", "GROW", "Q_MIN", "NORM_S_FLOOR", "FlowRuleError"]

TOL = float(4 * np.finfo(float).eps)  # relative size of the last step (or bracket) at convergence
MAX_ITER = 200                  # Newton/bisection iterations inside the bracket
MAX_EXPAND = 180                # bracket growth steps: GROW**180 ~ 1e162
GROW = 8.0
Q_MIN = 1e-154                  # q below this: p = q^2 underflows, returned as p = 0
NORM_S_FLOOR = 1e-150           # ||S|| used in the residual where ||S|| = 0


class FlowRuleError(ValueError):
    """The flow rule (4.2) has no positive solution for p at a state (or the solve failed there)."""


#: numba source of the scalar solve; ``_flow_residual(q, phi, div_u, norm_S, M, Psi, params)``
#: (returning F and dF/dq) is a global of the module it is compiled in (see :mod:`.codegen`)
SCALAR_SOLVER = f'''

@njit(**_OPTIONS)
def sqrt_pressure(phi, div_u, norm_S, M, Psi, params):
    """q = sqrt(p) solving the flow rule (4.2) with (2.9): bracketed Newton (icidr_pde.rheology.implicit)."""
    s = norm_S
    q = 1.0
    F, Fq = _flow_residual(q, phi, div_u, s, M, Psi, params)
    if not math.isfinite(F) and not norm_S > {NORM_S_FLOOR!r}:
        s = {NORM_S_FLOOR!r}
        F, Fq = _flow_residual(q, phi, div_u, s, M, Psi, params)
    if not math.isfinite(F):
        raise ValueError("flow rule (4.2): the residual is not finite at (phi, div_u, norm_S) =", phi, div_u, norm_S)
    if F == 0.0:
        return q
    lo = q
    hi = q
    if F < 0.0:
        found = False
        for k in range({MAX_EXPAND}):
            lo = hi
            hi = hi * {GROW!r}
            F, Fq = _flow_residual(hi, phi, div_u, s, M, Psi, params)
            if F >= 0.0:
                found = True
                break
        if not found:
            raise ValueError("flow rule (4.2): no positive solution for p (residual < 0 up to p = 1e308) at "
                             "(phi, div_u, norm_S) =", phi, div_u, norm_S)
        q = hi
    else:
        found = False
        for k in range({MAX_EXPAND}):
            hi = lo
            lo = lo / {GROW!r}
            if lo < {Q_MIN!r}:
                return 0.0
            F, Fq = _flow_residual(lo, phi, div_u, s, M, Psi, params)
            if F <= 0.0:
                found = True
                break
        if not found:
            return 0.0
        q = lo
    for it in range({MAX_ITER}):
        if F == 0.0:
            return q
        if F < 0.0:
            lo = q
        else:
            hi = q
        new = q - F / Fq
        if not (new > lo and new < hi):
            new = math.sqrt(lo * hi)
        if abs(new - q) <= {TOL!r} * new or hi - lo <= {TOL!r} * hi:
            return new
        q = new
        F, Fq = _flow_residual(q, phi, div_u, s, M, Psi, params)
        if not math.isfinite(F):
            raise ValueError("flow rule (4.2): the residual is not finite at (phi, div_u, norm_S) =",
                             phi, div_u, norm_S)
    raise ValueError("flow rule (4.2): the scalar solve for p did not converge at (phi, div_u, norm_S) =",
                     phi, div_u, norm_S)
'''


def solve_increasing(residual, phi, div_u, norm_S, M, Psi, params, raise_on_failure=True):
    """q = sqrt(p) with residual(q, phi, div_u, norm_S, M, Psi, params) = (F, dF/dq) = 0, F increasing.

    The iteration of :data:`SCALAR_SOLVER`, vectorised over broadcast numpy arrays (see the
    module docstring). Raises :class:`FlowRuleError` naming the first failing state; with
    ``raise_on_failure=False`` returns (q, failed) instead, q = nan where `failed`.
    """
    phi, div_u, norm_S, M, Psi = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                                       (phi, div_u, norm_S, M, Psi)))
    shape = phi.shape
    phi, div_u, norm_S, M, Psi = (np.ravel(x).copy() for x in (phi, div_u, norm_S, M, Psi))
    s = norm_S.copy()

    def res(q, i):
        with np.errstate(all="ignore"):
            F, Fq = residual(q, phi[i], div_u[i], s[i], M[i], Psi[i], params)
        return (np.array(np.broadcast_to(np.asarray(F, float), q.shape)),
                np.array(np.broadcast_to(np.asarray(Fq, float), q.shape)))

    failed = np.zeros(phi.size, bool)

    def fail(mask, what):
        if not np.any(mask):
            return
        if not raise_on_failure:
            failed[mask] = True
            return
        i = int(np.flatnonzero(mask)[0])
        raise FlowRuleError(f"flow rule (4.2) with (2.9): {what} at phi = {phi[i]:.6g}, div_u = {div_u[i]:.6g}, "
                            f"norm_S = {norm_S[i]:.6g}")

    n = phi.size
    q = np.ones(n)
    F, Fq = res(q, np.arange(n))
    floor = ~np.isfinite(F) & ~(norm_S > NORM_S_FLOOR)
    if np.any(floor):
        s[floor] = NORM_S_FLOOR
        F[floor], Fq[floor] = res(q[floor], np.flatnonzero(floor))
    fail(~np.isfinite(F), "the residual is not finite")
    lo, hi = q.copy(), q.copy()
    zero = np.zeros(n, bool)
    up = (F < 0) & ~failed                      # grow the bracket up where F < 0 ...
    todo = up.copy()
    for _ in range(MAX_EXPAND):
        i = np.flatnonzero(todo)
        if i.size == 0:
            break
        lo[i] = hi[i]
        hi[i] = hi[i] * GROW
        Fi, Fqi = res(hi[i], i)
        done = Fi >= 0
        F[i[done]], Fq[i[done]], q[i[done]] = Fi[done], Fqi[done], hi[i[done]]
        todo[i[done]] = False
    fail(todo, "no positive solution for p (residual < 0 up to p = 1e308)")
    todo = (F > 0) & ~up & ~failed              # ... and down where F > 0
    for _ in range(MAX_EXPAND):
        i = np.flatnonzero(todo)
        if i.size == 0:
            break
        hi[i] = lo[i]
        lo[i] = lo[i] / GROW
        small = lo[i] < Q_MIN
        zero[i[small]] = True                   # p below the float range: p = 0
        todo[i[small]] = False
        i = i[~small]
        Fi, Fqi = res(lo[i], i)
        done = Fi <= 0
        F[i[done]], Fq[i[done]], q[i[done]] = Fi[done], Fqi[done], lo[i[done]]
        todo[i[done]] = False
    zero |= todo
    out = np.where(zero, 0.0, q)
    active = ~zero & ~failed & (F != 0)
    for _ in range(MAX_ITER):
        i = np.flatnonzero(active)
        if i.size == 0:
            break
        qi, Fi, Fqi = q[i], F[i], Fq[i]
        neg = Fi < 0
        lo[i] = np.where(neg, qi, lo[i])
        hi[i] = np.where(neg, hi[i], qi)
        with np.errstate(all="ignore"):
            new = qi - Fi / Fqi
        outside = ~((new > lo[i]) & (new < hi[i]))
        new = np.where(outside, np.sqrt(lo[i] * hi[i]), new)
        converged = (np.abs(new - qi) <= TOL * new) | (hi[i] - lo[i] <= TOL * hi[i])
        out[i] = new
        active[i[converged]] = False
        i, new = i[~converged], new[~converged]
        q[i] = new
        F[i], Fq[i] = res(new, i)
        bad = np.zeros(n, bool)
        bad[i[~np.isfinite(F[i])]] = True
        fail(bad, "the residual is not finite")
        active &= ~bad
        exact = F[i] == 0
        active[i[exact]] = False
    fail(active, "the scalar solve for p did not converge")
    out[failed] = np.nan
    if not raise_on_failure:
        return out.reshape(shape), failed.reshape(shape)
    return out.reshape(shape)


class _ImplicitRootBase:
    """Marker base (sympy-free import of this module)."""


def implicit_root_class(name: str, residual, q, arg_symbols):
    """A sympy Function class for the root q of `residual` (in `q` and `arg_symbols`); see the docstring.

    `arg_symbols` are the placeholders (phi, div_u, norm_S, M, Psi, *parameters) in the order of
    the function's arguments.
    """
    import sympy as sp

    arg_symbols = tuple(arg_symbols)
    F = sp.sympify(residual)
    Fq = sp.diff(F, q)
    numeric = sp.lambdify((q, *arg_symbols), (F, Fq), modules="numpy")

    def residual_numpy(qv, phi, div_u, norm_S, M, Psi, params):
        return numeric(qv, phi, div_u, norm_S, M, Psi, *params)

    def _imp_(*args):
        args = [np.asarray(a, float) for a in args]
        return solve_increasing(residual_numpy, *args[:5], tuple(args[5:]))

    def solve(*args, raise_on_failure=True):
        args = [np.asarray(a, float) for a in args]
        return solve_increasing(residual_numpy, *args[:5], tuple(args[5:]), raise_on_failure=raise_on_failure)

    def fdiff(self, argindex=1):
        x = arg_symbols[argindex - 1]
        slope = -sp.diff(F, x) / Fq                       # implicit function theorem (sympy's idiff rule)
        return slope.xreplace({**dict(zip(arg_symbols, self.args)), q: self})

    def _eval_evalf(self, prec):
        import mpmath

        if not all(a.is_number for a in self.args):
            return None
        values = [sp.Float(a.evalf(prec), precision=prec) for a in self.args]
        start = float(_imp_(*[float(v) for v in values]))
        if start == 0.0:
            return sp.Float(0)
        f = sp.lambdify(q, F.xreplace(dict(zip(arg_symbols, values))), modules="mpmath")
        with mpmath.workprec(prec):
            root = mpmath.findroot(f, mpmath.mpf(start))
        return sp.Float(root, precision=prec)

    body = {"nargs": len(arg_symbols), "fdiff": fdiff, "_eval_evalf": _eval_evalf,
            "_imp_": staticmethod(_imp_), "solve": staticmethod(solve), "residual": F, "root_symbol": q, "arg_symbols": arg_symbols,
            "_eval_is_real": lambda self: True,
            "__doc__": f"sqrt(p) solving the flow rule of law {name!r}: {sp.sstr(F)} = 0 in {q}."}
    return type("sqrt_p_" + re.sub(r"\W", "_", name), (sp.Function, _ImplicitRootBase), body)


ImplicitRoot = _ImplicitRootBase
