"""The x-average of the 2-D cell's Jacobian in each layout of its entries: the one sum of its
couplings, and that sum computed by blocks of x-columns.

Every layout of the Jacobian's entries is averaged by :func:`add_couplings`, on the (row q, band
offset q' - q, x-offset dx, value) of its entries: each layout maps its own indices to those, a
column or a row at a time, and the sum is this one. The layouts: the whole Jacobian's CSC
columns, unknowns field-major (:func:`columns_average`, for
:func:`.xfourier_inverse.x_average`); the patch Jacobian's blocks of x-columns (:class:`XAverage`,
the serial default); PETSc's CSR rows of a rank, unknowns (z, x, field) (:func:`rows_average`, for
:mod:`.xfourier_shell`). They are all in this module because numba's disk cache of a function is
renewed when the function's own file changes, not when a function it calls changes in another.

The x-Fourier preconditioner (:mod:`.xfourier_inverse`) needs only the coefficients of each coupling
(field to field, z-row to z-row, x-offset) averaged over the cell's columns: O(Nz) numbers. The
whole analytic sparse Jacobian, from which they were averaged, is ~670 bytes a cell, and its
chain-rule products peak at ~3.2 kB a cell while it is built (docs/scaling.md, "Where the serial
default's bytes go"): at 2048^2 that alone is 13 GB. Here the Jacobian rows of one block of
x-columns at a time are built from the scheme's patch Jacobian (:class:`~icidr_pde.cells.plane2d.pde.Patches`,
the rows a distributed engine builds for its block) and added into the average, so that what is
held beside the run is one block's products, not the grid's.

The sums are those of the whole Jacobian's average, term by term and in the same order (each
coupling's terms by ascending x-column of the Jacobian's column, as the CSC walk of
:func:`columns_average` adds them): the block's rows are those of the
whole grid's Jacobian, and each block contributes the columns x in [a, b), whose rows are the
block's x in [a - 1, b + 1).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ...kernel_cache import numba_saves_may_fail

numba_saves_may_fail()  # a full disk under the numba cache costs a recompilation, not the run

__all__ = ["BLOCK_CELLS", "BLOCK_CELL_BYTES", "XAverage", "add_couplings", "block_bytes", "columns_average",
           "columns_reach", "rows_average", "triples"]

#: the cells of one block of x-columns (rounded to whole columns, at least one)
BLOCK_CELLS = 2**15
#: per cell of a block (its own columns and the two beside them whose rows it needs): the chain-rule
#: products while they are built and the patch operators kept for the next average; measured, the
#: peak RSS above the per-cell growth at 256^2 and 512^2 (~158 MB for blocks of ~33 000 cells:
#: docs/scaling.md, the memory section), with a quarter to spare
BLOCK_CELL_BYTES = 6_000.0


def block_bytes(cells: int) -> float:
    """The memory of one block of a grid of `cells` cells (whole x-columns of at most BLOCK_CELLS
    cells, and their two neighbours: a quarter more where Nz <= BLOCK_CELLS / 8)."""
    return BLOCK_CELL_BYTES * min(cells, 1.25 * BLOCK_CELLS)


class XAverage:
    """average(t, y) -> (average, band, reach) of the Jacobian at the state y, averaged over x.

    Args:
        patches: the scheme's :class:`~icidr_pde.cells.plane2d.pde.Patches` (rates and Jacobian on
            blocks of cells with ghost layers; x periodic, walls in z)
        block_cells: the cells of one block (whole x-columns, at least one)

    average (m (2 band + 1), 2 reach + 1), m = fields Nz: row q = fields iz + f, band position
    q' - q + band (q' = fields (iz + dz) + g), x-offset dx + reach of the coupling of unknown
    (f, ix, iz) to (g, ix + dx, iz + dz), divided by Nx and summed over ix; band and reach the
    largest |q' - q| and |dx| of the couplings present. The unknowns are field-major
    (field, x, z), the patches' state data flattened.
    """

    def __init__(self, patches, block_cells: int = BLOCK_CELLS):
        self.patches = patches
        self.fields = int(patches.dof)
        self.nx, self.nz = (int(s) for s in patches.shape)
        self.stencil = int(patches.stencil)
        self.columns = max(1, min(self.nx, int(block_cells) // self.nz))

    def __call__(self, t, y):
        fields, nx, nz, width = self.fields, self.nx, self.nz, self.stencil
        data = np.asarray(y, dtype=float).reshape(fields, nx, nz)
        band_max = fields * (width + 1) - 1  # z-offsets up to the stencil's width
        out = np.zeros((fields * nz, 2 * band_max + 1, 2 * width + 1))
        reach = np.zeros(2, dtype=np.int64)
        for a in range(0, nx, self.columns):
            b = min(nx, a + self.columns)
            # the rows of the columns [a, b) are those of x in [a - w, b + w), their patch x in [a - 2w, b + 2w)
            rows = (b - a) + 2 * width
            g = np.zeros((fields, rows + 2 * width, nz + 2 * width))
            g[:, :, width:nz + width] = np.take(data, np.arange(a - 2 * width, b + 2 * width), axis=1, mode="wrap")
            J = self.patches.jacobian(g, True, True).tocsc()  # rows (f, ix, iz), columns the patch's (g, px, pz)
            outside = _add_block(J.indptr, J.indices, J.data, fields, nx, nz, rows, width, out, reach)
            if outside:
                raise RuntimeError(f"{outside} couplings of the patch Jacobian reach beyond its stencil of width {width}")
        band, dx = int(reach[0]), int(reach[1])
        average = out[:, band_max - band:band_max + band + 1, width - dx:width + dx + 1]
        return np.ascontiguousarray(average).reshape(fields * nz * (2 * band + 1), 2 * dx + 1), band, dx


@njit(cache=True)
def add_couplings(q, offset, dx, values, nx, out, extent):
    """out[q, band + offset, reach + dx] += value / Nx for each (q, offset, dx, value) in turn, band
    and reach out's half-widths (out (rows, 2 band + 1, 2 reach + 1): :class:`XAverage`'s layout,
    q the row of `out`); extent = (largest |offset|, largest |dx|) of those added, kept from earlier
    calls. Returns how many lie beyond band or reach (not added). In the order given: the sums'
    rounding is that order's."""
    band, reach = (out.shape[1] - 1) // 2, (out.shape[2] - 1) // 2
    outside = 0
    for i in range(q.size):
        o, d = offset[i], dx[i]
        if abs(o) > band or abs(d) > reach:
            outside += 1
            continue
        out[q[i], band + o, reach + d] += values[i] / nx
        extent[0] = max(extent[0], abs(o))
        extent[1] = max(extent[1], abs(d))
    return outside


@njit(cache=True)
def triples(indptr):
    """Work arrays (q, offset, dx) for :func:`add_couplings`, as long as the longest column (row) of
    the compressed matrix of `indptr`: a layout maps one column (row) into them at a time."""
    longest = 0
    for j in range(indptr.size - 1):
        longest = max(longest, indptr[j + 1] - indptr[j])
    return np.empty(longest, np.int64), np.empty(longest, np.int64), np.empty(longest, np.int64)


@njit(cache=True)
def _add_block(indptr, indices, data, fields, nx, nz, rows, width, out, reach):
    """out[q, band_max + q' - q, width + dx] += J / Nx over the block's CSC entries whose column
    is one of the block's own x-columns (patch x in [2 width, rows)); reach = (largest |q' - q|,
    largest |dx|) of those entries (module notes); returns how many lie beyond out's band and
    reach."""
    px, pz = rows + 2 * width, nz + 2 * width
    q, offset, dx = triples(indptr)
    outside = 0
    for col in range(indptr.size - 1):
        f_col, cell = divmod(col, px * pz)
        x_col, z_pad = divmod(cell, pz)
        start, stop = indptr[col], indptr[col + 1]
        if x_col < 2 * width or x_col >= rows or start == stop:
            continue
        z_col = z_pad - width  # a wall ghost's column is folded into the edge row's: empty
        for e in range(start, stop):
            f_row, cell = divmod(indices[e], rows * nz)
            x_row, z_row = divmod(cell, nz)
            i = e - start
            q[i] = fields * z_row + f_row
            offset[i] = fields * z_col + f_col - q[i]
            dx[i] = x_col - width - x_row
        n = stop - start
        outside += add_couplings(q[:n], offset[:n], dx[:n], data[start:stop], nx, out, reach)
    return outside


@njit(cache=True)
def _coupling(row, col, fields, nx, nz):
    """(q, q' - q, dx) of the coupling of field-major unknown `row` to unknown `col` (unknown
    (field * Nx + ix) * Nz + iz, x periodic: dx the nearest image)."""
    f_row, cell = divmod(row, nx * nz)
    x_row, z_row = divmod(cell, nz)
    f_col, cell = divmod(col, nx * nz)
    x_col, z_col = divmod(cell, nz)
    q = fields * z_row + f_row
    return q, fields * z_col + f_col - q, (x_col - x_row + nx // 2) % nx - nx // 2


@njit(cache=True)
def columns_reach(indptr, indices, fields, nx, nz, out):
    """out = (largest |band offset| along z, largest |x offset|) of the CSC pattern's couplings,
    unknowns field-major of (fields, nx, nz)."""
    for col in range(indptr.size - 1):
        for e in range(indptr[col], indptr[col + 1]):
            _, band, dx = _coupling(indices[e], col, fields, nx, nz)
            out[0] = max(out[0], abs(band))
            out[1] = max(out[1], abs(dx))


@njit(cache=True)
def columns_average(indptr, indices, data, fields, nx, nz, out):
    """out[q, band + q' - q, reach + dx] += J / Nx over the CSC entries of J, unknowns field-major
    of (fields, nx, nz), a column at a time; returns how many lie beyond out's band and reach."""
    q, offset, dx = triples(indptr)
    extent = np.zeros(2, np.int64)
    outside = 0
    for col in range(indptr.size - 1):
        start, stop = indptr[col], indptr[col + 1]
        for e in range(start, stop):
            q[e - start], offset[e - start], dx[e - start] = _coupling(indices[e], col, fields, nx, nz)
        n = stop - start
        outside += add_couplings(q[:n], offset[:n], dx[:n], data[start:stop], nx, out, extent)
    return outside


@njit(cache=True)
def rows_average(indptr, indices, data, start, dof, nx, first_q, out):
    """out[q - first_q, band + q' - q, reach + dx] += P / Nx over the CSR rows of one rank of
    PETSc's matrix P (global row `start` + i), unknowns numbered (z, x, field) with `dof` fields
    (q = dof z + field, as the other layouts' rows), a row at a time; returns how many lie beyond
    out's band and reach."""
    q, offset, dx = triples(indptr)
    extent = np.zeros(2, np.int64)
    outside = 0
    for i in range(indptr.size - 1):
        row = start + i
        z_row, rest = divmod(row, nx * dof)
        x_row, f_row = divmod(rest, dof)
        q_row = dof * z_row + f_row
        first, stop = indptr[i], indptr[i + 1]
        for e in range(first, stop):
            z_col, rest = divmod(indices[e], nx * dof)
            x_col, f_col = divmod(rest, dof)
            q[e - first] = q_row - first_q
            offset[e - first] = dof * z_col + f_col - q_row
            dx[e - first] = (x_col - x_row + nx // 2) % nx - nx // 2
        n = stop - first
        outside += add_couplings(q[:n], offset[:n], dx[:n], data[first:stop], nx, out, extent)
    return outside
