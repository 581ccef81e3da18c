"""Chebyshev spectral collocation of the shear cell (``cheb``): the py-pde class.

The scheme is :mod:`.cheb_core` (py-pde-free: points, D, walls, kernels);
:class:`ChebyshevShearCellPDE` is its adapter to py-pde. py-pde grids are uniform, so the
state lives on a *carrier* ``CartesianGrid([[0, H]], N)`` of N cells, which is used for
storage only; :meth:`~.base.ShearCell1DBase.nodes` gives the true positions.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...rheology import Material, Rheology
from ...discretizations.base import ShearCell1DBase
from .cell import Shear1D
from .cheb_core import interpolate
from ...discretizations.chebyshev import cc_weights, cgl_nodes, cheb, clencurt, diff_matrix

__all__ = ["ChebyshevShearCellPDE", "cheb", "clencurt", "cgl_nodes", "diff_matrix", "cc_weights",
           "interpolate"]


class ChebyshevShearCellPDE(ShearCell1DBase):
    """Gravity-free 1-D shear cell (3.1)-(3.3), Chebyshev collocation (Trefethen's ``cheb``).

    Args:
        rheology, material, V0: as for :class:`~icidr_pde.discretizations.base.ShearCellBase`

    The state is stored on the carrier grid of :meth:`make_grid` (N cells used only as
    storage); data[k, j] is field k at the collocation point :meth:`nodes` [j].
    """

    name = "cheb"
    #: the cell it discretizes (the names of its grid, its Jacobian structure: :mod:`icidr_pde.cells`)
    cell = Shear1D.registered()

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, **options):
        super().__init__(rheology, material, V0=V0, **options)

    @property
    def expression(self) -> str:
        return (f"shear cell ({self.rheology.name}, Chebyshev): d_t phi = -D(phi w); "
                "d_t u = D tau_xz/phi - w D u; d_t w = D(tau_zz - p)/phi - w D w")

    def check_grid(self, grid) -> None:
        super().check_grid(grid)
        if grid.axes_bounds[0][0] != 0:
            raise ValueError("the carrier grid must start at z = 0")

    def operators(self, grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z, D, c): CGL points, differentiation matrix and Clenshaw-Curtis weights."""
        core = self.core(grid)
        return core.z, core.D, core.weights

    def interleaving(self, state) -> None:
        """None: no banded ordering exists for a dense collocation Jacobian."""
        return None

    def jacobian_sparsity(self, state) -> None:
        """None: the Jacobian of a collocation scheme is dense."""
        return None

    def make_jacobian(self, state) -> Callable:
        """Analytic dense Jacobian jac(t, y) (3N x 3N) of the flattened right-hand side
        (:meth:`.cheb_core.Collocation.make_jacobian`)."""
        return self.core(state.grid).make_jacobian()
