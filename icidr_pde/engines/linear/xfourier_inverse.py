"""The x-average of the Jacobian as CVODE's preconditioner on the x-periodic 2-D cell.

CVODE's BDF solves (I - gamma J) x = r at every Newton iteration. The 2-D cell's scenes are
steady shear, which does not depend on x, plus a perturbation; where the state does not depend
on x, J commutes with the shifts along the periodic axis, and the FFT in x splits
I - gamma J into one banded system along z per x-wave number: the Nx / 2 + 1 systems of the
real FFT, of 3 Nz unknowns each, factored by LAPACK's banded LU (``zgbtrf``), solve the Newton
system exactly in O(cells log Nx) work.

The preconditioner is that operator for the x-average of J: the coefficients of each coupling
(field to field, z-row to z-row, x-offset) averaged over the cell's columns. Where the state
depends on x it is the exact inverse of an approximation whose error is the coefficients'
departure from their x-average, which does not grow with the grid: on iCIDR bump2d GMRES(20)
to 1e-6 at gamma = 0.05 takes 4-6 iterations at 64^2 and 128^2 from t = 0.5 on (the bump has
spread; 21 and 30 at t = 0.1, 40 and 71 at t = 0 where the bump is sharpest), against 51 and
113 without a preconditioner (benchmarks/precond2d.py --amg-only --time 0, 0.1, 0.5).

* The factors are rebuilt from the averaged coefficients whenever gamma changes (Nx / 2 + 1
  banded LUs), the average whenever CVODE asks for a new Jacobian.
* Mass: the phi rows of J sum to zero in every column (c J = 0, c = 1 on phi), so do those of
  its x-average, and the mass lives in the x-mean (wave number 0) alone: the solve keeps c z = c r
  to round-off. The output is still corrected as :mod:`.amg_hierarchy`'s (a multiple of a fixed vector),
  so that round-off does not accumulate in the Krylov vectors.
"""

from __future__ import annotations

import os

# the band solves' OpenMP threads (numba's 'omp' layer) wait passively between parallel regions:
# spinning ones take the cores from everything else on a shared machine, and from each other when
# the machine is loaded (docs/scaling.md, "Threads that wait"). Read when numba starts its threads;
# a setting of the user's is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402  (after the setting above)
from numba import njit, prange  # noqa: E402
from scipy import sparse
from scipy.linalg import lapack

from ...kernel_cache import numba_saves_may_fail
from ...validation import ParameterError
from .precond import jacobian_precond
from .x_average import columns_average, columns_reach

numba_saves_may_fail()  # a full disk under the numba cache costs a recompilation, not the run

__all__ = ["XFourierPreconditioner", "XFourierFactors", "x_average", "xfourier_preconditioner"]


class XFourierPreconditioner:
    """(I - gamma A)^-1 for A the x-average of J, by the real FFT in x and banded LUs in z.

    Args:
        J: the sparse Jacobian, unknowns field-major in py-pde's layout: index
            (field * Nx + ix) * Nz + iz, x periodic
        shape: (fields, Nx, Nz)
        gamma: the step coefficient the factors are built for
        averaged: instead of J, its (average, band, reach) (:func:`x_average`), e.g. computed by
            blocks of x-columns without the whole J (:mod:`.x_average`)

    The coupling of unknown (f, ix, iz) to (g, ix + dx, iz + dz) becomes, averaged over ix, the
    coefficient of row q = fields * iz + f and band position q' - q (q' = fields * (iz + dz) + g)
    with phase exp(2 pi i k dx / Nx) in wave number k (:func:`x_average`); :class:`XFourierFactors`
    factors and solves the banded systems.
    """

    def __init__(self, J, shape, gamma: float, averaged=None):
        fields, nx, nz = (int(s) for s in shape)
        if averaged is None:
            if J.shape != (fields * nx * nz,) * 2:
                raise ParameterError(f"`J` must be {fields * nx * nz} x {fields * nx * nz} for `shape` {shape}; "
                                     f"got {J.shape}")
            averaged = x_average(J, (fields, nx, nz))
        self.fields, self.nx, self.nz = fields, nx, nz
        average, band, reach = averaged
        self.factors = XFourierFactors(average, nx, band, reach)
        self.gamma = None
        self.at(gamma)

    def at(self, gamma: float):
        """Factor I - gamma A_k for every wave number k."""
        if gamma == self.gamma:
            return
        self.factors.factor(-gamma, 1.0)
        self.gamma = gamma

    def solve(self, r, out=None):
        """z = (I - gamma A)^-1 r (field-major vectors); into `out` if given."""
        fields, nx, nz = self.fields, self.nx, self.nz
        spectrum = np.fft.rfft(np.reshape(r, (fields, nx, nz)), axis=1)   # (fields, modes, nz)
        columns = np.ascontiguousarray(spectrum.transpose(1, 2, 0)).reshape(nx // 2 + 1, nz * fields)
        self.factors.solve(columns)
        spectrum = columns.reshape(nx // 2 + 1, nz, fields).transpose(2, 0, 1)
        z = np.fft.irfft(spectrum, n=nx, axis=1).reshape(-1)
        if out is None:
            return z
        out[:] = z
        return out


class XFourierFactors:
    """The banded LU factors of D I + s A_k along z, A_k the x-averaged operator in x-wave number
    k, for the wave numbers `modes` of the real FFT, and their solve on data laid out by wave number.

    Args:
        average: the x-averaged coefficients, (m (2 band + 1), 2 reach + 1): row q (of m = fields
            Nz, q = fields iz + f), band position q' - q + band, x-offset dx + reach (as
            :func:`x_average` gives them)
        nx: the cells along x (the phases exp(2 pi i k dx / Nx))
        band: the largest |q' - q| of a coupling
        reach: the largest |dx| of a coupling
        modes: the wave numbers factored here (a range, of 0 ... Nx // 2); None: all of them

    The CVODE preconditioner factors I - gamma A_k (s = -gamma, D = 1); an operator whose
    coefficients already hold its diagonal (PETSc's shift I - J) is factored with s = 1 and D the
    change of that diagonal since it was averaged.
    """

    def __init__(self, average, nx: int, band: int, reach: int, modes=None):
        self.kl = self.ku = band = int(band)
        dx = int(reach)
        m = average.shape[0] // (2 * band + 1)
        self.average = average
        self.modes = range(nx // 2 + 1) if modes is None else modes
        self.phases = np.exp(2j * np.pi * np.outer(np.arange(-dx, dx + 1), np.asarray(self.modes)) / nx)
        rows = np.arange(m)[:, None]
        cols = rows + np.arange(2 * band + 1)[None, :] - band
        inside = (cols >= 0) & (cols < m)
        # LAPACK's band storage of (row, col): ab[kl + ku + row - col, col]
        self._ab_index = ((self.kl + self.ku + rows - cols)[inside], cols[inside])
        self._inside = np.flatnonzero(inside)
        count = len(self.modes)
        self.lu = np.zeros((count, 2 * self.kl + self.ku + 1, m), dtype=complex)
        self.reciprocal = np.zeros((count, m), dtype=complex)
        self.pivots = np.zeros((count, m), dtype=np.int32)

    def factor(self, scale: float, diagonal: float):
        """Factor `diagonal` I + `scale` A_k for every wave number k of `modes`."""
        ab = np.zeros(self.lu.shape[1:], dtype=complex)
        diagonal_slot = self.ku  # band position 0 of each row
        for j in range(self.lu.shape[0]):
            # a sum over the few x-offsets, not a BLAS product: OpenBLAS's threads stall a loaded machine
            symbol = sum(self.average[:, d] * self.phases[d, j] for d in range(self.phases.shape[0]))
            matrix = (scale * symbol).reshape(-1, 2 * self.ku + 1)
            matrix[:, diagonal_slot] += diagonal
            ab[self._ab_index] = matrix.reshape(-1)[self._inside]
            lu, pivots, info = lapack.zgbtrf(ab, self.kl, self.ku)
            if info != 0:
                raise np.linalg.LinAlgError(f"the x-averaged operator is singular at x-wave number "
                                            f"{self.modes[j]} (scale {scale}, diagonal {diagonal})")
            self.lu[j], self.pivots[j] = lu, pivots
            self.reciprocal[j] = 1.0 / lu[self.kl + self.ku]

    def solve(self, columns):
        """columns[j] = (D I + s A_k)^-1 columns[j], k = modes[j], in place: `columns`
        (len(modes), m) complex, C-contiguous, row q of each column as in `average`."""
        _band_solve(self.lu, self.reciprocal, self.pivots, self.kl, self.ku, columns)


def x_average(J, shape):
    """(average, band, reach) of the sparse Jacobian J of field-major unknowns of `shape` (fields,
    Nx, Nz): the coefficients of each coupling averaged over the columns x, as
    :class:`XFourierFactors` takes them (:func:`.x_average.columns_average`)."""
    fields, nx, nz = shape
    J = sparse.csc_matrix(J)
    reach = np.zeros(2, dtype=np.int64)
    columns_reach(J.indptr, J.indices, fields, nx, nz, reach)
    band, dx = int(reach[0]), int(reach[1])
    m = fields * nz
    average = np.zeros((m, 2 * band + 1, 2 * dx + 1))
    columns_average(J.indptr, J.indices, J.data, fields, nx, nz, average)
    return average.reshape(m * (2 * band + 1), 2 * dx + 1), band, dx


@njit(cache=True, parallel=True)
def _band_solve(lu, reciprocal, pivots, kl, ku, b):
    """b[k] = A_k^-1 b[k] for LAPACK's banded LU factors (zgbtrf) of each A_k, `reciprocal` the
    inverses of U's diagonal: zgbtrs, no transpose. The wave numbers are independent: numba's
    threads share them (NUMBA_NUM_THREADS)."""
    modes, m = b.shape
    kd = kl + ku
    for k in prange(modes):
        x = b[k]
        a = lu[k]
        for j in range(m - 1):  # L: row interchanges and the unit lower band
            p = pivots[k, j]  # scipy returns them 0-based
            if p != j:
                x[j], x[p] = x[p], x[j]
            xj = x[j]
            for i in range(1, min(kl, m - 1 - j) + 1):
                x[j + i] -= a[kd + i, j] * xj
        for j in range(m - 1, -1, -1):  # U: upper band of width kl + ku
            xj = x[j] * reciprocal[k, j]
            x[j] = xj
            for i in range(max(0, j - kd), j):
                x[i] -= a[kd + i - j, j] * xj


def xfourier_preconditioner(jac, shape, weights=None, averaged=None):
    """CVODE's left preconditioner: :class:`XFourierPreconditioner` of the analytic sparse Jacobian.

    Args:
        jac: the analytic sparse Jacobian jac(t, y), unknowns field-major (None with `averaged`)
        shape: (fields, Nx, Nz) of the unknowns
        weights: the mass weights c (c J = 0) of the conserved quantity, or None
        averaged: averaged(t, y) -> (average, band, reach) of the Jacobian at y (:mod:`.x_average`:
            by blocks of x-columns, without the whole J), or None: averaged from jac(t, y)

    The x-average is rebuilt when CVODE asks for a new Jacobian (jok false), the factors whenever
    gamma changes. With `weights` the output keeps c z = c r (module notes).
    """
    if averaged is not None:
        return jacobian_precond(averaged, lambda a, gamma: XFourierPreconditioner(None, shape, gamma, averaged=a),
                                weights)
    return jacobian_precond(jac, lambda J, gamma: XFourierPreconditioner(J, shape, gamma), weights)
