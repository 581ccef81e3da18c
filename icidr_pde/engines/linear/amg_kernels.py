"""Compiled V-cycle of :mod:`icidr_pde.engines.linear.amg_hierarchy`: all levels in one call.

The levels' operators are 3 x 3 block-sparse rows (one block row a cell or an aggregate, the
cell's fields phi, u, w its three unknowns), concatenated level after level and split into the
blocks left of the diagonal (``lptr``, ``lcol``, ``L``), the diagonal blocks (``D``, inverted in
``Dinv``) and the blocks right of it (``uptr``, ``ucol``, ``U``): ``lptr`` has one entry per
node of all levels and one more, pointing into ``lcol`` (the global node index of each block,
i.e. already offset by its level's first node) and ``L``; the same for U. A forward sweep from
zero reads L alone, the residual after it U alone, a backward sweep both, each as one stream.
Node ``i`` of a level that is not the coarsest belongs to coarse node ``agg[i]`` (global) with
prolongation block ``Pb[i]`` (the tentative prolongator has one block per fine row), R = P^T.
The coarsest level is solved by its dense inverse. Work vectors ``x``, ``b`` hold (node, field)
for every level.

Why one call: the per-level work of the V-cycle through scipy and pyamg (two Gauss-Seidel and
three matrix-vector calls a level, array allocations) cost seconds of Python overhead in a
128^2 run (docs/scaling.md, "Where the time of `--jacobian amg` goes"). The split into L and U lets each pass read only the
blocks it needs, without a test per block (storing the blocks in float32 to read half the
bytes did not change a run's time: not kept).
"""

import numpy as np
from numba import njit

from ...kernel_cache import numba_saves_may_fail

numba_saves_may_fail()  # a full disk under the numba cache costs a recompilation, not the run

__all__ = ["set_gamma", "vcycle"]


@njit(cache=True)
def _inv3(a, out):
    """out = inverse of the 3 x 3 block a (cofactors; the diagonal blocks of I - gamma C are
    close to I)."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    r = 1.0 / det
    out[0, 0] = c00 * r
    out[1, 0] = c01 * r
    out[2, 0] = c02 * r
    out[0, 1] = (a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]) * r
    out[1, 1] = (a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]) * r
    out[2, 1] = (a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]) * r
    out[0, 2] = (a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]) * r
    out[1, 2] = (a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]) * r
    out[2, 2] = (a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) * r


@njit(cache=True)
def set_gamma(gamma, CL, CD, CU, L, D, U, Dinv):
    """L, D, U = the blocks of I - gamma C (the identity on the diagonal blocks), Dinv = D^-1."""
    for k in range(CL.shape[0]):
        for p in range(3):
            for q in range(3):
                L[k, p, q] = -gamma * CL[k, p, q]
    for k in range(CU.shape[0]):
        for p in range(3):
            for q in range(3):
                U[k, p, q] = -gamma * CU[k, p, q]
    for i in range(CD.shape[0]):
        for p in range(3):
            for q in range(3):
                D[i, p, q] = (1.0 if p == q else 0.0) - gamma * CD[i, p, q]
        _inv3(D[i], Dinv[i])


@njit(cache=True, fastmath=True)
def _subtract(i, ptr, col, B, x, s0, s1, s2):
    """(s0, s1, s2) minus the sum over row i's blocks of B of B x (scalars: kept in registers)."""
    for k in range(ptr[i], ptr[i + 1]):
        j = col[k]
        x0 = x[j, 0]
        x1 = x[j, 1]
        x2 = x[j, 2]
        s0 -= B[k, 0, 0] * x0 + B[k, 0, 1] * x1 + B[k, 0, 2] * x2
        s1 -= B[k, 1, 0] * x0 + B[k, 1, 1] * x1 + B[k, 1, 2] * x2
        s2 -= B[k, 2, 0] * x0 + B[k, 2, 1] * x1 + B[k, 2, 2] * x2
    return s0, s1, s2


@njit(cache=True, fastmath=True)
def _solve_diagonal(i, Dinv, s0, s1, s2, x):
    x[i, 0] = Dinv[i, 0, 0] * s0 + Dinv[i, 0, 1] * s1 + Dinv[i, 0, 2] * s2
    x[i, 1] = Dinv[i, 1, 0] * s0 + Dinv[i, 1, 1] * s1 + Dinv[i, 1, 2] * s2
    x[i, 2] = Dinv[i, 2, 0] * s0 + Dinv[i, 2, 1] * s1 + Dinv[i, 2, 2] * s2


@njit(cache=True, fastmath=True)
def vcycle(r, z, nodes, lptr, lcol, L, uptr, ucol, U, Dinv, agg, Pb, coarse_inv, x, b):
    """z = one V(1,1) cycle on (I - gamma J) z = r from zero: forward block Gauss-Seidel, the
    residual restricted, the coarse correction prolongated, backward block Gauss-Seidel.

    r and z are field-major (all cells of field 0, then 1, 2); ``nodes`` holds the first node
    of each level and one past the last.
    """
    levels = nodes.size - 1
    cells = nodes[1]
    for c in range(cells):
        for f in range(3):
            b[c, f] = r[f * cells + c]
    for level in range(levels - 1):
        lo, hi = nodes[level], nodes[level + 1]
        for i in range(lo, hi):  # forward sweep from zero: the blocks left of the diagonal
            s0, s1, s2 = _subtract(i, lptr, lcol, L, x, b[i, 0], b[i, 1], b[i, 2])
            _solve_diagonal(i, Dinv, s0, s1, s2, x)
        for m in range(hi, nodes[level + 2]):
            b[m, 0] = 0.0
            b[m, 1] = 0.0
            b[m, 2] = 0.0
        for i in range(lo, hi):
            # after a forward sweep from zero, row i's residual is what the blocks right of the
            # diagonal (not yet updated when x_i was) contribute
            s0, s1, s2 = _subtract(i, uptr, ucol, U, x, 0.0, 0.0, 0.0)
            m = agg[i]
            b[m, 0] += Pb[i, 0, 0] * s0 + Pb[i, 1, 0] * s1 + Pb[i, 2, 0] * s2
            b[m, 1] += Pb[i, 0, 1] * s0 + Pb[i, 1, 1] * s1 + Pb[i, 2, 1] * s2
            b[m, 2] += Pb[i, 0, 2] * s0 + Pb[i, 1, 2] * s1 + Pb[i, 2, 2] * s2
    lo = nodes[levels - 1]
    n = 3 * (nodes[levels] - lo)
    for p in range(n):
        acc = 0.0
        for q in range(n):
            acc += coarse_inv[p, q] * b[lo + q // 3, q % 3]
        x[lo + p // 3, p % 3] = acc
    for level in range(levels - 2, -1, -1):
        lo, hi = nodes[level], nodes[level + 1]
        for i in range(lo, hi):
            m = agg[i]
            x0 = x[m, 0]
            x1 = x[m, 1]
            x2 = x[m, 2]
            x[i, 0] += Pb[i, 0, 0] * x0 + Pb[i, 0, 1] * x1 + Pb[i, 0, 2] * x2
            x[i, 1] += Pb[i, 1, 0] * x0 + Pb[i, 1, 1] * x1 + Pb[i, 1, 2] * x2
            x[i, 2] += Pb[i, 2, 0] * x0 + Pb[i, 2, 1] * x1 + Pb[i, 2, 2] * x2
        for i in range(hi - 1, lo - 1, -1):  # backward sweep
            s0, s1, s2 = _subtract(i, lptr, lcol, L, x, b[i, 0], b[i, 1], b[i, 2])
            s0, s1, s2 = _subtract(i, uptr, ucol, U, x, s0, s1, s2)
            _solve_diagonal(i, Dinv, s0, s1, s2, x)
    for c in range(cells):
        for f in range(3):
            z[f * cells + c] = x[c, f]
