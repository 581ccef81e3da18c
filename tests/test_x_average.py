"""The x-average of the 2-D cell's Jacobian by blocks of x-columns (:mod:`icidr_pde.engines.linear.x_average`).

Against independent truth: the average of the whole analytic sparse Jacobian
(:func:`icidr_pde.engines.linear.xfourier_inverse.x_average`, itself tested against the average of
the x-shifted Jacobians in tests/test_xfourier.py), bit for bit, on x-dependent states of both
rheologies and both advections, even and odd Nx, blocks that divide Nx and blocks that do not;
and the memory it holds: never the whole Jacobian. The third layout, PETSc's CSR rows of unknowns
(z, x, field) on ranks that split z (:func:`icidr_pde.engines.linear.x_average.rows_average`),
averages the same Jacobian to the same numbers: bit for bit where the state does not depend on x
(each coupling's terms are then equal, so their order does not matter), within the rounding of
sums of Nx terms in another order where it does.
"""

import tracemalloc

import numpy as np
import pytest
from scipy import sparse

from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
from icidr_pde.cells.plane2d.scenes import Bump2DScene
from icidr_pde.engines.linear.x_average import XAverage, rows_average
from icidr_pde.engines.linear.xfourier import XFourierGmres
from icidr_pde.engines.linear.xfourier_inverse import XFourierPreconditioner, x_average

pytestmark = pytest.mark.xdist_group("xfourier")


def _state(rheology, nx, nz, advection="central"):
    pde = ShearCell2DPDE(rheology, advection=advection)
    grid = pde.make_grid(None, 30.0, Nx=nx, Nz=nz)
    state = pde.make_state(grid, *Bump2DScene(ell=4.0).initial_condition(pde.nodes(grid)))
    y = state.data.ravel().copy()
    # velocities that depend on x and z everywhere: every coupling present, none symmetric
    y[nx * nz:] += 1e-3 * np.random.default_rng(nx * nz).standard_normal(2 * nx * nz)
    return pde, state, y


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["central", "upwind"])
@pytest.mark.parametrize("nx, nz, columns", [(8, 7, 3), (9, 6, 2), (4, 5, 1), (16, 12, 16), (12, 10, 100)])
def test_block_average_equals_the_whole_jacobians_bit_for_bit(rheology, advection, nx, nz, columns):
    pde, state, y = _state(rheology, nx, nz, advection)
    whole = x_average(pde.make_jacobian(state)(0.0, y), state.data.shape)
    blocks = XAverage(pde.patches(state), block_cells=columns * nz)(0.0, y)
    assert blocks[1:] == whole[1:] == (5, 1)  # band, x-reach of the 3 x 3 box stencil
    assert blocks[0].shape == whole[0].shape
    assert np.array_equal(blocks[0], whole[0])


def _rows_average(J, nx, nz, band, reach, splits):
    """The x-average of J by PETSc's layout: J's rows and columns renumbered (z, x, field), its
    CSR rows averaged rank by rank, the ranks owning the z-rows [0, splits[0]), [splits[0], ...)."""
    f, x, z = np.meshgrid(np.arange(3), np.arange(nx), np.arange(nz), indexing="ij")
    natural = ((z * nx + x) * 3 + f).ravel()  # field-major unknown -> its number in PETSc's layout
    renumber = sparse.csr_matrix((np.ones(natural.size), (natural, np.arange(natural.size))))
    P = (renumber @ J @ renumber.T).tocsr()
    P.sort_indices()
    parts = []
    for zs, ze in zip((0, *splits), (*splits, nz)):
        rows = P[3 * nx * zs:3 * nx * ze]
        part = np.zeros((3 * (ze - zs), 2 * band + 1, 2 * reach + 1))
        assert rows_average(rows.indptr, rows.indices, rows.data, 3 * nx * zs, 3, nx, 3 * zs, part) == 0
        parts.append(part)
    return np.concatenate(parts).reshape(-1, 2 * reach + 1)


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("nx, nz, columns, splits", [(8, 7, 3, (3,)), (9, 6, 2, ()), (16, 12, 5, (4, 9))])
def test_the_three_layouts_average_alike(rheology, nx, nz, columns, splits):
    pde = ShearCell2DPDE(rheology)
    grid = pde.make_grid(None, 30.0, Nx=nx, Nz=nz)
    z = pde.nodes(grid)[..., 1]
    steady = pde.make_state(grid, 0.78 + 0.01 * np.sin(z / 5), z / 30 + 0.02 * np.sin(z / 3),
                            0.01 * np.sin(np.pi * z / 30))  # no x-dependence
    pde_bump, bump, y_bump = _state(rheology, nx, nz)
    for pde, state, y in ((pde, steady, steady.data.ravel().copy()), (pde_bump, bump, y_bump)):
        J = pde.make_jacobian(state)(0.0, y)
        whole, band, reach = x_average(J, state.data.shape)
        blocks = XAverage(pde.patches(state), block_cells=columns * nz)(0.0, y)
        rows = _rows_average(J, nx, nz, band, reach, splits)
        assert (band, reach) == blocks[1:] == (5, 1)
        assert np.array_equal(blocks[0], whole)
        if state is steady:
            assert np.array_equal(rows, whole)
        else:  # sums of Nx terms J / Nx in two orders: each within (Nx - 1) eps sum|J| / Nx of the exact sum
            magnitude = x_average(abs(J), state.data.shape)[0]
            assert np.all(np.abs(rows - whole) <= 2 * (nx - 1) * np.finfo(float).eps * magnitude)


def test_preconditioner_from_the_block_average_solves_as_from_the_jacobian():
    pde, state, y = _state("icidr", 10, 8)
    r = np.random.default_rng(4).standard_normal(y.size)
    from_J = XFourierPreconditioner(pde.make_jacobian(state)(0.0, y), state.data.shape, 0.2)
    averaged = XAverage(pde.patches(state), block_cells=3 * 8)(0.0, y)
    from_blocks = XFourierPreconditioner(None, state.data.shape, 0.2, averaged=averaged)
    assert np.array_equal(from_blocks.solve(r), from_J.solve(r))


def test_the_fourier_runs_never_hold_the_whole_jacobian():
    """The 'fourier' spec carries the block average, not the analytic Jacobian; the average's
    peak (tracemalloc: numpy and scipy.sparse) on 128 x 64 cells in blocks of 4 columns stays
    below half the whole Jacobian's own CSC arrays."""
    pde, state, y = _state("icidr", 128, 64)
    spec = XFourierGmres().jacobian_spec(pde, state, "fourier")
    assert spec.jac is None and isinstance(spec.x_average, XAverage)
    J = pde.make_jacobian(state)(0.0, y)
    whole_bytes = J.data.nbytes + J.indices.nbytes + J.indptr.nbytes
    del J
    average = XAverage(pde.patches(state), block_cells=4 * 64)
    average(0.0, y)  # compiled, its patch operators built
    tracemalloc.start()
    try:
        average(0.0, y)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 0.5 * whole_bytes
