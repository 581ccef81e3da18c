"""Compiled validity tests of the integrator's state vector: lo < phi < hi at every node.

CVODE evaluates its root function (the margins) at every step and in its root search, so
these run on the integrator's own vector, phi being every `stride`-th entry from `start`
(the interleaved or the native ordering), without copies or reordering.
"""

import numpy as np
from numba import njit

from ..kernel_cache import numba_saves_may_fail

numba_saves_may_fail()  # a full disk under the numba cache costs a recompilation, not the run

__all__ = ["margins_into", "inside"]


@njit(cache=True)
def margins_into(y, start, stride, n, lo, hi, out):
    """out[0] = min(phi) - lo, out[1] = hi - max(phi): both positive while the state is valid."""
    low = np.inf
    high = -np.inf
    for k in range(n):
        value = y[start + k * stride]
        low = min(low, value)
        high = max(high, value)
    out[0] = low - lo
    out[1] = hi - high


@njit(cache=True)
def inside(y, start, stride, n, lo, hi):
    """True if every entry of y is finite and lo < phi < hi at every node."""
    for k in range(y.size):
        if not np.isfinite(y[k]):
            return False
    for k in range(n):
        value = y[start + k * stride]
        if not (lo < value < hi):
            return False
    return True
