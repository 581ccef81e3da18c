"""Chebyshev collocation of the shear cell in numpy, written independently of the compiled
kernels (``templates/cheb.py``): the oracle the contract tests compare them with."""

from typing import Callable

import numpy as np

__all__ = ["make_cheb_rates", "numpy_rhs"]


def make_cheb_rates(stress: Callable) -> Callable:
    """Numpy ``rates(phi, u, w, D, params) -> (3, N) array`` at the collocation points."""

    def rates(phi, u, w, D, params):
        uz = D @ u
        wz = D @ w
        p, txz, tzz = stress(phi, uz, wz, params)
        fw = tzz - p
        out = np.empty((3, phi.shape[0]))
        out[0] = -(D @ (phi * w))
        out[1] = (D @ txz) / phi - w * uz
        out[2] = (D @ fw) / phi - w * wz
        out[1:, [0, -1]] = 0.0
        return out

    return rates


def numpy_rhs(pde, grid):
    """rhs(data, t) of the collocation scheme in numpy."""
    D = pde.operators(grid)[1]
    rates = make_cheb_rates(pde.rheology.kernels(pde.kinematics).stress_numpy)
    params = pde.material.params

    def rhs(state_data, t=0.0):
        return rates(state_data[0], state_data[1], state_data[2], D, params)

    return rhs
