"""Finite volumes for the 1-D shear cell on py-pde's cell-centred grid (``fd``): the py-pde class.

The scheme is :mod:`.fd_core` (py-pde-free); :class:`ShearCellPDE` is its adapter to py-pde
(grid, FieldCollection state, ``solve``) and to the stiff integrator (the flat block
ordering of ``state.data.ravel()``, the interleaving in which the Jacobian is banded). The
walls are the core's ghost-cell maps; py-pde's boundary conditions ``bc_phi``, ``bc_u``,
``bc_w`` describe the same walls (a test compares py-pde's setters with the maps).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...rheology import Material, Rheology
from ...discretizations.base import ShearCell1DBase
from .cell import Shear1D
from ...discretizations.registry import ADVECTION_SCHEMES

__all__ = ["ShearCellPDE", "ADVECTION_SCHEMES"]


class ShearCellPDE(ShearCell1DBase):
    """Gravity-free 1-D shear cell (3.1)-(3.3) closed by a rheology, finite volumes.

    Args:
        rheology, material, V0: as for :class:`~icidr_pde.discretizations.base.ShearCellBase`
        advection: 'upwind' (first order, default) or 'central' (second order) for w d_z
    """

    name = "fd"
    #: the cell it discretizes (the names of its grid, its Jacobian structure: :mod:`icidr_pde.cells`)
    cell = Shear1D.registered()

    def __init__(self, rheology: str | Rheology = "icidr", material: Material | None = None,
                 *, V0: float = 1.0, advection: str = "upwind", **options):
        super().__init__(rheology, material, V0=V0, advection=advection, **options)
        self.bc_phi = {"derivative": 0}
        self.bc_u = {"x-": {"value": 0.0}, "x+": {"value": self.V0}}
        self.bc_w = {"value": 0.0}

    @property
    def expression(self) -> str:
        return (f"shear cell ({self.rheology.name}, finite volumes): d_t phi = -d_z(phi w); "
                "d_t u = d_z tau_xz/phi - w d_z u; d_t w = d_z(tau_zz - p)/phi - w d_z w")

    def ghost_coefficients(self, grid) -> np.ndarray:
        """(3, 2, 2) array: ghost value of field k at side s (0: z = 0, 1: z = H) is
        ``c[k, s, 0] * edge + c[k, s, 1]`` (:func:`icidr_pde.discretizations.core.ghost_coefficients`)."""
        return self.core(grid).ghost.copy()

    # --- what the stiff integrator asks of a discretization ----------------------------------

    def jacobian_sparsity(self, state):
        """Block-tridiagonal pattern of the Jacobian (scipy CSR): every field couples to i-1, i, i+1."""
        from scipy import sparse

        core = self.core(state.grid)
        perm = core.interleaving()[0]
        rows, cols = core.band_pattern()
        n3 = 3 * core.N
        return sparse.csr_matrix((np.ones(rows.size), (perm[rows], perm[cols])), shape=(n3, n3))

    def interleaving(self, state):
        """Ordering (phi_0, u_0, w_0, phi_1, ...) in which the Jacobian is banded.

        Returns the permutation `perm` (interleaved = flat[perm]) and the lower and upper
        bandwidths (5, 5): cell i couples to cells i - 1 .. i + 1.
        """
        return self.core(state.grid).interleaving()

    def make_band_jacobian(self, state) -> Callable:
        """jac_into(y, J): the analytic Jacobian in the ordering of :meth:`interleaving`
        (`y` interleaved), written by the compiled kernel into the band of the dense (3N, 3N)
        array `J` (entries outside the cells' 3 x 3 blocks are left untouched)."""
        return self.core(state.grid).make_band_jacobian(state.data)

    def make_jacobian(self, state) -> Callable:
        """Analytic sparse Jacobian jac(t, y) (scipy CSC) of the flattened right-hand side: the
        compiled band kernel's entries, moved to the block ordering."""
        from scipy import sparse

        core = self.core(state.grid)
        band = core.make_jacobian_band()
        perm = core.interleaving()[0]
        rows, cols = core.band_pattern()
        lband = core.interleaving()[1]
        flat_rows, flat_cols, n3 = perm[rows], perm[cols], 3 * core.N
        band_index = (cols, rows - cols + lband)

        def jacobian(t, y):
            jb = band(np.asarray(y, dtype=float)[perm])
            return sparse.csc_matrix((jb[band_index], (flat_rows, flat_cols)), shape=(n3, n3))

        return jacobian
