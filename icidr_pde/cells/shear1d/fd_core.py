"""Finite volumes of the 1-D shear cell, py-pde-free (``fd``): the scheme itself.

Non-dimensional equations (3.13)-(3.15) for mu(I),Phi(I) and (5.3)-(5.5) for iCIDR,
written with the momentum fluxes F_u = tau_xz and F_w = tau_zz - p:

.. math::
    \\partial_t \\phi = -\\partial_z(\\phi w), \\qquad
    \\partial_t u = \\frac{1}{\\phi}\\partial_z F_u - w \\partial_z u, \\qquad
    \\partial_t w = \\frac{1}{\\phi}\\partial_z F_w - w \\partial_z w,

on N cells of 0 < z < H (h = H/N, centres (i + 1/2) h, py-pde's CartesianGrid([[0, H]], N))
with walls u(0) = 0, u(H) = V0, w(0) = w(H) = 0 (3.9):

* the fluxes are evaluated on the N + 1 cell faces from the compact differences
  (u_{i+1} - u_i)/h and the face average of phi (no central-of-central stencil, so
  no undamped checkerboard mode);
* phi is in conservative flux form; the face flux phi w vanishes at the walls because
  the Dirichlet ghost value of w is -w_edge, so the mass integral is conserved to
  round-off and phi needs no physical boundary condition (its zero-gradient ghost value
  only enters the wall stress);
* advection is first-order upwind (default, as the paper's first-order differences) or
  central;
* every wall enters through one ghost cell a side, the affine map alpha * (edge value) +
  beta of :func:`ghost_coefficients` (a test compares it with py-pde's boundary setters).

The kernels (rates and the analytic band Jacobian) are ``templates/fd.py``, compiled by
numba for any law and printed as C for the native engine; the engines' state vector is
interleaved, y[3 i + k] = field k of cell i, in which the Jacobian is banded (5, 5).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...discretizations.core import Scheme1D, ghost_coefficients

__all__ = ["FiniteVolumes", "BAND"]

#: lower and upper bandwidths of the Jacobian in the interleaved ordering: cell i couples to i - 1 .. i + 1
BAND = (5, 5)


class FiniteVolumes(Scheme1D):
    """Finite volumes of the shear cell on N cells of height H (see the module docstring).

    Args:
        rheology, N, H, material, V0: as for :class:`~.core.Scheme1D`
        advection: 'upwind' (first order, default) or 'central' (second order) for w d_z
    """

    name = "fd"
    interleaved = True

    def __init__(self, rheology="icidr", N=None, H=30.0, *, material=None, V0=1.0, **options):
        super().__init__(rheology, N, H, material=material, V0=V0, **options)
        self.h = self.H / self.N
        self.z = (np.arange(self.N) + 0.5) * self.h
        self.weights = np.full(self.N, self.h)
        self.ghost = np.ascontiguousarray(ghost_coefficients(self.V0))

    @property
    def upwind(self) -> bool:
        return self.advection == "upwind"

    def integral(self, values) -> float:
        """Midpoint rule over 0 < z < H (exact for the mass)."""
        return float(np.sum(values) * self.h)

    def padded(self, data) -> np.ndarray:
        """(3, N + 2) data with the ghost values of the walls."""
        data = np.asarray(data, float)
        c = self.ghost
        g = np.empty((3, data.shape[1] + 2))
        g[:, 1:-1] = data
        g[:, 0] = c[:, 0, 0] * data[:, 0] + c[:, 0, 1]
        g[:, -1] = c[:, 1, 0] * data[:, -1] + c[:, 1, 1]
        return g

    def strain_rates(self, data) -> tuple[np.ndarray, ...]:
        """Face positions and (phi, u_z, w_z) on the faces, where the stresses live."""
        phi_g, u_g, w_g = self.padded(data)
        z_f = np.linspace(0.0, self.H, self.N + 1)
        return z_f, 0.5 * (phi_g[1:] + phi_g[:-1]), np.diff(u_g) / self.h, np.diff(w_g) / self.h

    # --- compiled kernels ---------------------------------------------------------------------

    def make_rates(self, probe=None, contiguous: bool = True) -> Callable:
        """rhs(data, t) -> (3, N) rates of (3, N) data, the compiled kernel (cached on disk);
        compiled or loaded now, on `probe` data (default: a uniform state); with
        `contiguous` False, a wrapper that py-pde's numba backend can compile (it copies nothing)."""
        from ...rheology.codegen import first_call

        loops = self.loops()
        kernel, ghost, h, upwind, params = loops.rates, self.ghost, self.h, self.upwind, self.material.params

        if not contiguous:  # py-pde's numba backend compiles this: C-contiguous float data given
            def rhs(data, t=0.0):
                out = np.empty(data.shape)
                kernel(data, ghost, h, upwind, params, out)
                return out
        else:
            def rhs(data, t=0.0):
                out = np.empty(data.shape)
                kernel(np.ascontiguousarray(data, dtype=float), ghost, h, upwind, params, out)
                return out

        first_call(loops, lambda: rhs(self._probe() if probe is None else probe), f"{self.rheology.name} on fd")
        return rhs

    def _probe(self) -> np.ndarray:
        lo, hi = self.material.phi_range
        return self.sample(0.5 * (lo + min(hi, 1.0)), 0.0, 0.0)

    def interleaving(self) -> tuple[np.ndarray, int, int]:
        """(perm, lband, uband): interleaved = blocks[perm], and the bandwidths there."""
        perm = (np.arange(self.N)[:, None] + self.N * np.arange(3)[None, :]).ravel()
        return (perm, *BAND)

    def make_band_jacobian(self, probe=None) -> Callable:
        """jac_into(y, J): the analytic Jacobian at the interleaved state `y`, written by the
        compiled kernel into the band of the (3N, 3N) array `J` (entries outside the cells'
        3 x 3 blocks are left untouched)."""
        n = self.N
        kernel = self.loops().jacobian_interleaved
        ghost, h, upwind, params = self.ghost, self.h, self.upwind, self.material.params

        def jac_into(y, J):  # a fresh C copy (CVODE's y is read-only): one compiled signature
            kernel(np.array(y, dtype=float).reshape(n, 3).T, ghost, h, upwind, params, J)

        # compile or load now, on 4 cells: the kernel's types, not a dense (3N, 3N) array
        data = self._probe() if probe is None else np.asarray(probe, float)
        kernel(np.array(data[:, :4].T, dtype=float).reshape(4, 3).T, ghost, h, upwind, params, np.zeros((12, 12)))
        return jac_into

    def make_jacobian_band(self) -> Callable:
        """band(y) -> jb (3N, 11): the analytic Jacobian at the interleaved state `y` as
        jb[col, row - col + 5] (the native engine's band layout), zero outside the cells'
        3 x 3 blocks. The compiled kernel writes through a strided view of jb whose [row, col]
        is jb[col, row - col + 5] (the kernel writes only inside the band)."""
        n3 = 3 * self.N
        lband, uband = BAND
        width = lband + uband + 1
        kernel = self.loops().jacobian_interleaved
        ghost, h, upwind, params = self.ghost, self.h, self.upwind, self.material.params
        item = np.dtype(float).itemsize

        def band(y):
            jb = np.zeros((n3, width))
            view = np.lib.stride_tricks.as_strided(jb[:, uband:], shape=(n3, n3),
                                                   strides=(item, (width - 1) * item))
            kernel(np.array(y, dtype=float).reshape(self.N, 3).T, ghost, h, upwind, params, view)
            return jb

        return band

    def band_pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) in the interleaved ordering of the entries the band Jacobian holds:
        every (cell i, field k) couples to every field of cells i - 1 .. i + 1."""
        n = self.N
        cell_r, cell_c = [], []
        for offset in (-1, 0, 1):
            cells = np.arange(max(0, -offset), min(n, n - offset))
            cell_r.append(cells)
            cell_c.append(cells + offset)
        cell_r, cell_c = np.concatenate(cell_r), np.concatenate(cell_c)
        k, m = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
        rows = (3 * cell_r[:, None] + k.ravel()[None, :]).ravel()
        cols = (3 * cell_c[:, None] + m.ravel()[None, :]).ravel()
        return rows, cols
