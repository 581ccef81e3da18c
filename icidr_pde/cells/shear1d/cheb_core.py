"""Chebyshev collocation of the 1-D shear cell, py-pde-free (``cheb``): the scheme itself.

The paper computes every case twice, with first-order differences and with a Chebyshev
spectral scheme (Trefethen 2000, *Spectral Methods in MATLAB*, program ``cheb``). This is
that second discretization, of the same equations as :mod:`.fd_core`:

.. math::
    \\partial_t \\phi = -D(\\phi w), \\qquad
    \\partial_t u = \\frac{1}{\\phi} D F_u - w D u, \\qquad
    \\partial_t w = \\frac{1}{\\phi} D F_w - w D w,

with F_u = tau_xz(phi, Du, Dw), F_w = tau_zz - p, collocated at the N
Chebyshev-Gauss-Lobatto points z_j = H (1 - cos(pi j/(N - 1)))/2, j = 0..N-1, walls
included; D is Trefethen's differentiation matrix mapped to [0, H] (:mod:`.chebyshev`).

* u and w are Dirichlet (3.9): their wall values are part of the state, set by
  :meth:`Collocation.initial_data`, and their wall rates are 0.
* phi evolves at every node including the walls, in flux form -D(phi w). Since
  Clenshaw-Curtis quadrature with N points is exact for the degree N-2 polynomial
  D(phi w), the discrete mass sum_j c_j phi_j changes at the rate
  -(phi w)(H) + (phi w)(0) = 0: mass is conserved to round-off.
* the Jacobian is dense: the chain rule D diag(dF/d.) D with the law's exact partials.
* the kernels are ``templates/cheb.py`` combined with the law (D is an argument, so one
  compilation per law serves every N); the same template, printed as C, is the native
  engine's. The engines' state vector holds the fields in blocks (phi, u, w).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...discretizations.chebyshev import cc_weights, cgl_nodes, diff_matrix
from ...discretizations.core import Scheme1D

__all__ = ["Collocation", "interpolate"]


def interpolate(values: np.ndarray, z_eval, H: float) -> np.ndarray:
    """Evaluate the polynomial interpolating `values` at the N CGL points of [0, H] at `z_eval`.

    Barycentric formula with the CGL weights (-1)^j, halved at both ends (Trefethen,
    *Approximation Theory and Approximation Practice*, thm 5.2); `values` may have
    leading axes (..., N).
    """
    values = np.asarray(values, dtype=float)
    N = values.shape[-1]
    z = cgl_nodes(N, H)
    lam = (-1.0) ** np.arange(N)
    lam[[0, -1]] *= 0.5
    z_eval = np.atleast_1d(np.asarray(z_eval, dtype=float))
    diff = z_eval[:, None] - z[None, :]
    exact = diff == 0
    diff[exact] = 1.0
    kernel = lam / diff
    kernel[np.any(exact, axis=1)] = exact[np.any(exact, axis=1)].astype(float)
    return (values @ kernel.T) / kernel.sum(axis=1)


class Collocation(Scheme1D):
    """Chebyshev collocation of the shear cell at N CGL points of [0, H] (module docstring).

    Args: as for :class:`~.core.Scheme1D` (no options)
    """

    name = "cheb"

    def __init__(self, rheology="icidr", N=None, H=30.0, *, material=None, V0=1.0, **options):
        super().__init__(rheology, N, H, material=material, V0=V0, **options)
        self.z = cgl_nodes(self.N, self.H)
        self.D = diff_matrix(self.N, self.H)
        self.weights = cc_weights(self.N, self.H)

    def initial_data(self, phi, u, w) -> np.ndarray:
        """The fields at the points, with the wall values of u and w set to the Dirichlet data
        (3.9), u = 0, V0 and w = 0 (the IC (3.16) meets them to within 1e-97)."""
        data = self.sample(phi, u, w)
        data[1, [0, -1]] = 0.0, self.V0
        data[2, [0, -1]] = 0.0
        return data

    def strain_rates(self, data) -> tuple[np.ndarray, ...]:
        """(z, phi, u_z, w_z) at the collocation points, where the stresses live."""
        return self.z.copy(), np.array(data[0]), self.D @ data[1], self.D @ data[2]

    # --- compiled kernels ---------------------------------------------------------------------

    def make_rates(self, probe=None, contiguous: bool = True) -> Callable:
        """rhs(data, t) -> (3, N) rates of (3, N) data, the compiled kernel (cached on disk);
        compiled or loaded now, on `probe` data (default: a uniform state); with
        `contiguous` False, a wrapper that py-pde's numba backend can compile (it copies nothing)."""
        from ...rheology.codegen import first_call

        loops = self.loops()
        kernel, D, params = loops.rates, self.D, self.material.params

        if not contiguous:  # py-pde's numba backend compiles this: C-contiguous float data given
            def rhs(data, t=0.0):
                out = np.empty(data.shape)
                kernel(data, D, params, out)
                return out
        else:
            def rhs(data, t=0.0):
                out = np.empty(data.shape)
                kernel(np.ascontiguousarray(data, dtype=float), D, params, out)
                return out

        if probe is None:
            lo, hi = self.material.phi_range
            probe = self.initial_data(0.5 * (lo + min(hi, 1.0)), 0.0, 0.0)
        first_call(loops, lambda: rhs(probe), f"{self.rheology.name} on cheb")
        return rhs

    def make_jacobian(self) -> Callable:
        """jac(t, y) -> the dense (3N, 3N) Jacobian of the rates at the block state `y`: the
        template's chain rule (``assemble_jacobian``) on the law's exact partials and the
        products D diag(dF/d.) D, these evaluated by numpy (the law's numpy kernels and
        numpy's BLAS, whose dgemm differs from the one numba calls in the last bit at
        N = 201, so that the scipy runs keep their numbers to the last bit). The template's
        ``jacobian`` evaluates them in compiled code, for the native engine."""
        D, n = self.D, self.N
        assemble = self.loops().assemble_jacobian
        kernels, params = self.rheology.kernels(self.kinematics), self.material.params

        def jacobian(t, y):
            data = np.ascontiguousarray(y, dtype=float).reshape(3, n)
            uz, wz = D @ data[1], D @ data[2]
            p, txz, tzz = kernels.stress_numpy(data[0], uz, wz, params)
            d = kernels.stress_jacobian_numpy(data[0], uz, wz, params)
            dflux = np.array([*d[3:6], *(d[6 + k] - d[k] for k in range(3))])
            products = np.array([(D * dflux[3 * a + 1 + b][None, :]) @ D for a in (0, 1) for b in (0, 1)])
            J = np.empty((3 * n, 3 * n), order="F")  # the kernel writes down the columns
            assemble(data, D, uz, wz, np.array([txz, tzz - p]), dflux, products, J)
            return J

        return jacobian
