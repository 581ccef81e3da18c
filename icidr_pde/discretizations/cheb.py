"""Chebyshev spectral collocation of the shear cell (``cheb``), behind the same interface as py-pde.

The paper computes every case twice, with first-order differences and with a Chebyshev
spectral scheme (Trefethen 2000, *Spectral Methods in MATLAB*, program ``cheb``).
This module is that second discretization. It solves the same equations as
:mod:`icidr_pde.discretizations.fd` with the same generated kernels of :mod:`icidr_pde.rheology`:

.. math::
    \\partial_t \\phi = -D(\\phi w), \\qquad
    \\partial_t u = \\frac{1}{\\phi} D F_u - w D u, \\qquad
    \\partial_t w = \\frac{1}{\\phi} D F_w - w D w,

with F_u = tau_xz(phi, Du, Dw), F_w = tau_zz - p, collocated at the N
Chebyshev-Gauss-Lobatto points z_j = H (1 - cos(pi j/(N - 1)))/2, j = 0..N-1, walls
included; D is Trefethen's differentiation matrix mapped to [0, H].

* u and w are Dirichlet (3.9): their wall values are part of the state, set by
  :meth:`ChebyshevShearCellPDE.make_state`, and their wall rates are 0.
* phi evolves at every node including the walls, in flux form -D(phi w). Since
  Clenshaw-Curtis quadrature with N points is exact for the degree N-2 polynomial
  D(phi w), the discrete mass sum_j c_j phi_j changes at the rate
  -(phi w)(H) + (phi w)(0) = 0: mass is conserved to round-off.
* the Jacobian of the right-hand side is dense; :meth:`make_jacobian` builds it
  analytically by the chain rule, D diag(dF/d.) D, from the law's exact partials.
* the compiled right-hand side and Jacobian are ``templates/cheb.py`` combined with the law
  (:func:`icidr_pde.rheology.codegen.compose`): D is an argument, so one compilation per
  rheology serves every N, and it is cached on disk. The same template, printed as C, is
  the native engine's (:mod:`icidr_pde.native.translate`).

py-pde grids are uniform, so the state lives on a *carrier* ``CartesianGrid([[0, H]], N)``
of N cells, which is used for storage only; :meth:`nodes` gives the true positions.
"""

from __future__ import annotations

import importlib.resources
from typing import Callable

import numpy as np
from pde import CartesianGrid, FieldCollection
from pde.backends import get_backend

from ..rheology import Material, Rheology
from ..chebyshev import cc_weights, cgl_nodes, cheb, clencurt, diff_matrix
from ..grid_size import CHEB
from ..rheology.codegen import compose, first_call
from .base import ShearCellBase

__all__ = ["ChebyshevShearCellPDE", "cheb", "clencurt", "cgl_nodes", "diff_matrix", "cc_weights",
           "interpolate", "make_cheb_rates"]

_TEMPLATE = importlib.resources.files(__package__).joinpath("templates", "cheb.py").read_text()
_RHS_CACHE: dict = {}


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


class ChebyshevShearCellPDE(ShearCellBase):
    """Gravity-free 1-D shear cell (3.1)-(3.3), Chebyshev collocation (Trefethen's ``cheb``).

    Args:
        rheology, material, V0: as for :class:`~icidr_pde.discretizations.base.ShearCellBase`

    The state is stored on the carrier grid of :meth:`make_grid` (N cells used only as
    storage); data[k, j] is field k at the collocation point :meth:`nodes` [j].
    """

    name = "cheb"
    label = "Chebyshev"
    default_N = 65
    grid_limit = CHEB
    max_N = CHEB.max_N
    memory_note = CHEB.memory_note
    memory_estimate = staticmethod(CHEB.memory_estimate)

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, **options):
        super().__init__(rheology, material, V0=V0, **options)
        self._ops: dict = {}

    @property
    def expression(self) -> str:
        return (f"shear cell ({self.rheology.name}, Chebyshev): d_t phi = -D(phi w); "
                "d_t u = D tau_xz/phi - w D u; d_t w = D(tau_zz - p)/phi - w D w")

    # --- grid and operators --------------------------------------------------------

    def check_grid(self, grid) -> None:
        super().check_grid(grid)
        if grid.axes_bounds[0][0] != 0:
            raise ValueError("the carrier grid must start at z = 0")

    @staticmethod
    def _size(grid) -> tuple[int, float]:
        return int(grid.shape[0]), float(grid.axes_bounds[0][1])

    def operators(self, grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z, D, c): CGL points, differentiation matrix and Clenshaw-Curtis weights."""
        key = self._size(grid)
        if key not in self._ops:
            N, H = key
            self._ops[key] = (cgl_nodes(N, H), diff_matrix(N, H), cc_weights(N, H))
        return self._ops[key]

    def nodes(self, grid) -> np.ndarray:
        """The N Chebyshev-Gauss-Lobatto points z_j = H (1 - cos(pi j/(N-1)))/2."""
        return self.operators(grid)[0].copy()

    def integral(self, values: np.ndarray, grid) -> float:
        """Clenshaw-Curtis integral over 0 < z < H of values at the collocation points."""
        return float(np.dot(self.operators(grid)[2], values))

    def quadrature_weights(self, grid) -> np.ndarray:
        """Clenshaw-Curtis weights c of :meth:`integral` (integral = c . values)."""
        return self.operators(grid)[2].copy()

    def make_state(self, grid: CartesianGrid, phi, u, w) -> FieldCollection:
        """FieldCollection of phi, u, w sampled at :meth:`nodes` from callables or arrays.

        The wall values of u and w are set to the Dirichlet data (3.9), u = 0, V0 and
        w = 0 (the IC (3.16) meets them to within 1e-97).
        """
        state = super().make_state(grid, phi, u, w)
        state[1].data[[0, -1]] = 0.0, self.V0
        state[2].data[[0, -1]] = 0.0
        return state

    # --- right-hand side -------------------------------------------------------------

    def _loops(self):
        return compose(_TEMPLATE, self.rheology.kernels(self.kinematics), name="cheb")

    def make_rates(self, state: FieldCollection) -> Callable:
        """rhs(data, t) from the compiled collocation kernel (cached on disk, D an argument)."""
        self.check_grid(state.grid)
        D = self.operators(state.grid)[1]
        loops = self._loops()
        kernel = loops.rates
        params = self.material.params

        def rhs(data, t=0.0):
            out = np.empty(data.shape)
            kernel(np.ascontiguousarray(data, dtype=float), D, params, out)
            return out

        first_call(loops, lambda: rhs(state.data), f"{self.rheology.name} on {self.name}")
        return rhs

    def make_evolution_rate(self, state: FieldCollection, backend="numpy") -> Callable:
        """rhs(state_data, t) for py-pde's `numpy` (independent numpy code) or `numba` backend."""
        self.check_grid(state.grid)
        backend = get_backend(backend)
        D = self.operators(state.grid)[1]
        params = self.material.params
        if backend.name != "numpy":
            key = (self.rheology, self._size(state.grid))
            if key not in _RHS_CACHE:
                kernel = self._loops().rates

                def pde_rhs(state_data, t=0.0):
                    out = np.empty(state_data.shape)
                    kernel(state_data, D, params, out)
                    return out

                _RHS_CACHE[key] = pde_rhs  # py-pde compiles this thin wrapper
            return _RHS_CACHE[key]
        rates = make_cheb_rates(self.rheology.kernels(self.kinematics).stress_numpy)

        def numpy_rhs(state_data, t=0.0):
            return rates(state_data[0], state_data[1], state_data[2], D, params)

        return numpy_rhs

    # --- what the stiff integrator asks of a discretization ---------------------------

    def interleaving(self, state) -> None:
        """None: no banded ordering exists for a dense collocation Jacobian."""
        return None

    def jacobian_sparsity(self, state) -> None:
        """None: the Jacobian of a collocation scheme is dense."""
        return None

    def make_jacobian(self, state) -> Callable:
        """Analytic dense Jacobian jac(t, y) (3N x 3N) of the flattened right-hand side: the
        compiled chain rule of ``templates/cheb.py`` (``assemble_jacobian``) on the law's
        exact partials and the products D diag(dF/d.) D, evaluated here by numpy (the law's
        numpy kernels and numpy's BLAS, whose dgemm differs from the one numba calls in the
        last bit at N = 201), as before the template held the chain rule, so that the py-pde
        runs keep their numbers to the last bit. The template's ``jacobian`` evaluates them
        in compiled code, for the native engine."""
        self.check_grid(state.grid)
        D = self.operators(state.grid)[1]
        n = D.shape[0]
        assemble = self._loops().assemble_jacobian
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

    def strain_rates(self, data: np.ndarray, grid) -> tuple[np.ndarray, ...]:
        """(z, phi, u_z, w_z) at the collocation points, where the stresses live."""
        z, D, _ = self.operators(grid)
        return z.copy(), np.array(data[0]), D @ data[1], D @ data[2]

