"""Jacobian-vector products for CVODE's GMRES by difference quotients with a small increment.

CVODE's own product (``cvLsDQJtimes``) is Jv = [f(y + sigma v) - f(y)] / sigma with
sigma = 1 / ||v||_WRMS: the perturbation sigma v is as large as the error tolerance
(rtol |y| + atol in each component). On the 2-D cell at 1024^2 (iCIDR bump2d, rtol 1e-5) that
is large enough for the quotient's truncation error to break Newton's convergence: on the
command line's output schedule the step size collapsed from 2.1e-3 to 8.6e-5 at t = 0.04 with 4
Newton convergence failures (with GMRES(20) or GMRES(50) alike), where this product, whose
perturbation is :data:`INCREMENT` times the state's largest component, took the same run to
t = 0.07 in 44 steps without a failure, and the whole run to t = 10 in 132 steps (as 64^2-512^2
take), where with CVODE's it had not finished (the times: docs/scaling.md, "The banded solves on
both cores; 1024²").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..kernel_cache import numba_saves_may_fail

numba_saves_may_fail()  # a full disk under the numba cache costs a recompilation, not the run

__all__ = ["INCREMENT", "difference_jtimes"]

#: largest component of the perturbation sigma v, relative to max(1, max |y|)
INCREMENT = 1e-7


def difference_jtimes(fun_into, n: int):
    """CVODE's Jacobian-vector product (scikit-sundae's ``CVODEJacTimes``) of y' = f(t, y).

    Args:
        fun_into: fun_into(t, y, out) writes f(t, y) into `out`
        n: the number of unknowns

    Jv = [f(t, y + sigma v) - f(t, y)] / sigma, f(t, y) the value CVODE passes, sigma chosen so
    that max |sigma v| = INCREMENT max(1, max |y|): one right-hand side call per product, as CVODE's.
    """
    from sksundae.cvode import CVODEJacTimes

    perturbed, rate = np.empty(n), np.empty(n)

    def jtimes(t, y, fy, v, Jv):
        sigma = _perturb(y, v, INCREMENT, perturbed)
        if sigma == 0.0:
            Jv[:] = 0.0
            return
        fun_into(t, perturbed, rate)
        _quotient(rate, fy, sigma, Jv)

    return CVODEJacTimes(None, jtimes)


@njit(cache=True)
def _perturb(y, v, increment, out):
    """out = y + sigma v with max |sigma v| = increment * max(1, max |y|); returns sigma (0: v = 0)."""
    v_max, y_max = 0.0, 1.0
    for i in range(y.size):
        v_max = max(v_max, abs(v[i]))
        y_max = max(y_max, abs(y[i]))
    if v_max == 0.0:
        return 0.0
    sigma = increment * y_max / v_max
    for i in range(y.size):
        out[i] = y[i] + sigma * v[i]
    return sigma


@njit(cache=True)
def _quotient(rate, fy, sigma, out):
    """out = (rate - fy) / sigma."""
    for i in range(rate.size):
        out[i] = (rate[i] - fy[i]) / sigma
