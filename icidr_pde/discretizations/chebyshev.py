"""Chebyshev-Gauss-Lobatto operators on [0, H] (Trefethen 2000, *Spectral Methods in MATLAB*).

numpy only (no py-pde): the collocation scheme :mod:`icidr_pde.cells.shear1d.cheb` and the
native engine (:mod:`icidr_pde.native`) take their points, differentiation matrix and
quadrature weights from here, so both discretize with the same numbers.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cheb", "clencurt", "cgl_nodes", "diff_matrix", "cc_weights"]


def cheb(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Trefethen's ``cheb``: differentiation matrix D and points x_j = cos(pi j/n), j = 0..n.

    D is exact for polynomials of degree <= n on the n + 1 points (x descending from 1 to -1);
    the diagonal uses the negative-sum trick, so D annihilates constants to round-off.
    """
    if int(n) != n or n < 1:
        raise ValueError(f"`n` must be a positive integer; got {n}")
    n = int(n)
    j = np.arange(n + 1)
    x = np.cos(np.pi * j / n)
    c = np.where((j == 0) | (j == n), 2.0, 1.0) * (-1.0) ** j
    dX = x[:, None] - x[None, :]
    D = np.outer(c, 1.0 / c) / (dX + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    return D, x


def clencurt(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Trefethen's ``clencurt``: Clenshaw-Curtis points x_j = cos(pi j/n) and weights on [-1, 1]."""
    if int(n) != n or n < 1:
        raise ValueError(f"`n` must be a positive integer; got {n}")
    n = int(n)
    theta = np.pi * np.arange(n + 1) / n
    x = np.cos(theta)
    w = np.zeros(n + 1)
    ii = np.arange(1, n)
    v = np.ones(n - 1)
    if n % 2 == 0:
        w[0] = w[n] = 1.0 / (n**2 - 1)
        for k in range(1, n // 2):
            v -= 2.0 * np.cos(2 * k * theta[ii]) / (4 * k**2 - 1)
        v -= np.cos(n * theta[ii]) / (n**2 - 1)
    else:
        w[0] = w[n] = 1.0 / n**2
        for k in range(1, (n - 1) // 2 + 1):
            v -= 2.0 * np.cos(2 * k * theta[ii]) / (4 * k**2 - 1)
    w[ii] = 2.0 * v / n
    return x, w


def cgl_nodes(N: int, H: float) -> np.ndarray:
    """The N Chebyshev-Gauss-Lobatto points z_j = H (1 - cos(pi j/(N-1)))/2 on [0, H], ascending."""
    j = np.arange(N)
    z = 0.5 * H * (1.0 - np.cos(np.pi * j / (N - 1)))
    z[0], z[-1] = 0.0, float(H)  # exact walls
    return z


def diff_matrix(N: int, H: float) -> np.ndarray:
    """d/dz on the N CGL points of [0, H]: z = H (1 - x)/2, so D_z = -(2/H) D_x."""
    D, _ = cheb(N - 1)
    return np.ascontiguousarray(-2.0 / H * D)


def cc_weights(N: int, H: float) -> np.ndarray:
    """Clenshaw-Curtis weights of the N CGL points of [0, H] (exact to degree N - 1)."""
    _, w = clencurt(N - 1)
    return 0.5 * H * w
