"""Compiled V-cycle of :mod:`icidr_pde.engines.amg`: all levels in one call.

The levels' operators are 3 x 3 block-sparse rows (one block row a cell or an aggregate, the
cell's fields phi, u, w its three unknowns), concatenated level after level: ``ptr`` (one
entry per node of all levels, and one more) points into ``col`` (the global node index of each
block, i.e. already offset by its level's first node) and ``A`` (the blocks); ``diag`` is the
position of each row's diagonal block and ``Dinv`` its inverse. Node ``i`` of a level that is
not the coarsest belongs to coarse node ``agg[i]`` (global) with prolongation block ``Pb[i]``
(the tentative prolongator has one block per fine row), R = P^T. The coarsest level is solved
by its dense inverse. Work vectors ``x``, ``b`` hold (node, field) for every level.

Why one call: the per-level work of the V-cycle through scipy and pyamg (three Gauss-Seidel and
three matrix-vector calls a level, array allocations) cost ~2.5 s of Python overhead in the
32 s of a 128^2 run (docs/scaling.md), and the block sweeps are written here anyway.
"""

import numpy as np
from numba import njit

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
def set_gamma(gamma, C, A, diag, Dinv):
    """A = I - gamma C block by block (the identity on the diagonal blocks), Dinv their inverses."""
    for k in range(C.shape[0]):
        for p in range(3):
            for q in range(3):
                A[k, p, q] = -gamma * C[k, p, q]
    for i in range(diag.size):
        d = diag[i]
        for p in range(3):
            A[d, p, p] += 1.0
        _inv3(A[d], Dinv[i])


@njit(cache=True)
def _sweep(lo, hi, step, ptr, col, A, Dinv, x, b, lower_only):
    """One block Gauss-Seidel sweep over nodes lo, lo + step, ... (not hi); with lower_only the
    initial x is zero and only the blocks already updated in this sweep are read."""
    i = lo
    while i != hi:
        s0 = b[i, 0]
        s1 = b[i, 1]
        s2 = b[i, 2]
        for k in range(ptr[i], ptr[i + 1]):
            j = col[k]
            if j == i or (lower_only and j > i):
                continue
            x0 = x[j, 0]
            x1 = x[j, 1]
            x2 = x[j, 2]
            s0 -= A[k, 0, 0] * x0 + A[k, 0, 1] * x1 + A[k, 0, 2] * x2
            s1 -= A[k, 1, 0] * x0 + A[k, 1, 1] * x1 + A[k, 1, 2] * x2
            s2 -= A[k, 2, 0] * x0 + A[k, 2, 1] * x1 + A[k, 2, 2] * x2
        D = Dinv[i]
        x[i, 0] = D[0, 0] * s0 + D[0, 1] * s1 + D[0, 2] * s2
        x[i, 1] = D[1, 0] * s0 + D[1, 1] * s1 + D[1, 2] * s2
        x[i, 2] = D[2, 0] * s0 + D[2, 1] * s1 + D[2, 2] * s2
        i += step


@njit(cache=True)
def vcycle(r, z, nodes, ptr, col, A, Dinv, agg, Pb, coarse_inv, x, b):
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
        _sweep(lo, hi, 1, ptr, col, A, Dinv, x, b, True)
        for m in range(hi, nodes[level + 2]):
            b[m, 0] = 0.0
            b[m, 1] = 0.0
            b[m, 2] = 0.0
        for i in range(lo, hi):
            # after a forward sweep from zero, row i's residual is what the blocks above the
            # diagonal (not yet updated when x_i was) contribute
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            for k in range(ptr[i], ptr[i + 1]):
                j = col[k]
                if j <= i:
                    continue
                x0 = x[j, 0]
                x1 = x[j, 1]
                x2 = x[j, 2]
                s0 -= A[k, 0, 0] * x0 + A[k, 0, 1] * x1 + A[k, 0, 2] * x2
                s1 -= A[k, 1, 0] * x0 + A[k, 1, 1] * x1 + A[k, 1, 2] * x2
                s2 -= A[k, 2, 0] * x0 + A[k, 2, 1] * x1 + A[k, 2, 2] * x2
            m = agg[i]
            P = Pb[i]
            b[m, 0] += P[0, 0] * s0 + P[1, 0] * s1 + P[2, 0] * s2
            b[m, 1] += P[0, 1] * s0 + P[1, 1] * s1 + P[2, 1] * s2
            b[m, 2] += P[0, 2] * s0 + P[1, 2] * s1 + P[2, 2] * s2
    lo = nodes[levels - 1]
    n = 3 * (nodes[levels] - lo)
    for p in range(n):
        s = 0.0
        for q in range(n):
            s += coarse_inv[p, q] * b[lo + q // 3, q % 3]
        x[lo + p // 3, p % 3] = s
    for level in range(levels - 2, -1, -1):
        lo, hi = nodes[level], nodes[level + 1]
        for i in range(lo, hi):
            m = agg[i]
            P = Pb[i]
            x0 = x[m, 0]
            x1 = x[m, 1]
            x2 = x[m, 2]
            x[i, 0] += P[0, 0] * x0 + P[0, 1] * x1 + P[0, 2] * x2
            x[i, 1] += P[1, 0] * x0 + P[1, 1] * x1 + P[1, 2] * x2
            x[i, 2] += P[2, 0] * x0 + P[2, 1] * x1 + P[2, 2] * x2
        _sweep(hi - 1, lo - 1, -1, ptr, col, A, Dinv, x, b, False)
    for c in range(cells):
        for f in range(3):
            z[f * cells + c] = x[c, f]
