"""The x-Fourier preconditioner inside PETSc's KSP: a shell preconditioner (PC type 'python') on
the ranks of a DMDA split along z only.

The inverse is :mod:`.xfourier_inverse`'s (:class:`~.xfourier_inverse.XFourierFactors`: the
x-averaged coefficients -> one banded LU along z per x-wave number -> the solve); what is
distributed here is how its data reaches it:

* Each rank owns whole rows of cells along the periodic x (``proc_sizes`` (1, P)), so its
  x-average and its FFT in x are local. PETSc's numbering of the DMDA is then the natural one
  (z, x, field), rank after rank.
* The averaged coefficients: each rank averages its own rows of the preconditioning matrix
  (PETSc's shift I - J of the assembled Jacobian) over x (:func:`.x_average.rows_average`); the
  small arrays of all ranks are gathered on every rank (m (2 band + 1) (2 reach + 1) numbers for m = 3 Nz unknowns of a
  column), where a new Jacobian was assembled. Between Jacobians only the shift changes: its
  change is read from the matrix's diagonal (one reduction), and the banded systems are
  factored again, not averaged, where it moved by more than :data:`LAG`. The engine's Newton
  matrix (:class:`~icidr_pde.engines.petsc.NewtonMatrix`) gives its shift and scale as numbers
  and J assembled apart: J's rows are averaged, and the shift added to the factors.
* The solve: the real FFT in x of each rank's rows; one transpose to wave-number slabs (each rank
  then holds all z of its own wave numbers, Nx / 2 + 1 of them shared as evenly as they go)
  and the banded solves there; the transpose back and the inverse FFT. The transposes are one
  PETSc scatter (VecScatter, built once from two index sets) forward and the same scatter in
  reverse: PETSc's own communication, no second MPI binding to build against PETSc's MPI.
* On more than one rank the banded solves run on one thread per rank (numba's, unless
  NUMBA_NUM_THREADS is set): the ranks are the parallelism, and a rank's threads would take the
  cores of the others.

On a state that does not depend on x the preconditioner is the exact inverse of the matrix it is
given (tests/test_petsc_xfourier.py, on 1 and 2 ranks).
"""

from __future__ import annotations

import os

import numpy as np
from numba import set_num_threads

from .x_average import rows_average
from .xfourier_inverse import XFourierFactors

__all__ = ["XFourierShell", "LAG"]

#: the factors are kept while the mean of the matrix's diagonal (the shift, plus the mean of -J's
#: diagonal) stays within this fraction of the one they were factored at, as CVODE keeps its
#: preconditioner while gamma stays within 0.2 of its own (CVLS_DGMAX): between Jacobians most
#: Newton systems then reuse the factors, which cost Nx / 2 + 1 banded LUs each
LAG = 0.2


class XFourierShell:
    """petsc4py's context of a PC of type 'python': (x-average of the PC's matrix)^-1 by the FFT
    in x and banded LUs in z, each rank solving its own wave numbers (module notes).

    Args:
        PETSc: petsc4py's PETSc module
        da: the DMDA (x periodic, z bounded, `dof` fields interleaved), split along z only
        stencil: the box stencil's width (the couplings reach that many cells each way)

    :meth:`new_jacobian` says that the matrix's values are new (not only its shift): the next
    set-up averages them again. The matrix is an assembled one (its shift read from its diagonal)
    or the engine's Newton matrix of type 'python' (its shift and scale given as numbers).
    """

    def __init__(self, PETSc, da, stencil: int):
        self.PETSc = PETSc
        nx, nz = da.getSizes()
        dof = da.getDof()
        (xs, xe), (zs, ze) = da.getRanges()
        if (xs, xe) != (0, nx):
            raise ValueError(f"the x-Fourier preconditioner needs each rank to own whole rows along x (a DMDA "
                             f"split along z only, proc_sizes (1, P)); this rank owns x {xs}:{xe} of {nx}")
        comm = da.getComm()
        if comm.size > 1 and "NUMBA_NUM_THREADS" not in os.environ:
            set_num_threads(1)
        self.nx, self.nz, self.dof, self.zs, self.ze = nx, nz, dof, zs, ze
        self.band, self.reach = dof * (stencil + 1) - 1, stencil
        modes = nx // 2 + 1
        bounds = [modes * r // comm.size for r in range(comm.size + 1)]
        self.modes = range(bounds[comm.rank], bounds[comm.rank + 1])
        width = 2 * dof  # the real numbers of one (z, k): dof complex values
        self.spectrum = PETSc.Vec().createMPI(((ze - zs) * modes * width, None), comm=comm)
        self.columns = PETSc.Vec().createMPI((len(self.modes) * nz * width, None), comm=comm)
        k = np.arange(self.modes.start, self.modes.stop)[:, None, None]
        z = np.arange(nz)[None, :, None]
        w = np.arange(width)[None, None, :]
        to = ((k * nz + z) * width + w).ravel().astype(PETSc.IntType)  # wave-number slabs: (k, z, field)
        source = ((z * modes + k) * width + w).ravel().astype(PETSc.IntType)  # z slabs: (z, k, field)
        self.transpose = PETSc.Scatter().create(self.spectrum, PETSc.IS().createGeneral(source, comm=comm),
                                                self.columns, PETSc.IS().createGeneral(to, comm=comm))
        per_row = (2 * self.band + 1) * (2 * self.reach + 1)
        self.local_average = np.zeros((dof * (ze - zs), 2 * self.band + 1, 2 * self.reach + 1))
        self._mine = PETSc.Vec().createMPI((self.local_average.size, None), comm=comm)
        self._gather, self._all = PETSc.Scatter.toAll(self._mine)
        self.m, self.per_row = dof * nz, per_row
        self.factors, self.fresh, self._diagonal, self._averaged = None, True, None, None
        self.averaged_mean = self.factored_change = None
        self.jacobian_mean = self.factored_weight = self.factored_mean = None
        self.n_averages = self.n_factors = 0

    def new_jacobian(self):
        """The matrix's values are new: average them again at the next set-up."""
        self.fresh = True

    def setUp(self, pc):
        _, P = pc.getOperators()
        newton = P.getPythonContext() if P.getType() == self.PETSc.Mat.Type.PYTHON else None
        if newton is not None:
            self._set_up_newton(newton)
            return
        if self._diagonal is None:
            self._diagonal = P.createVecLeft()
        P.getDiagonal(self._diagonal)
        size = self._diagonal.getSize()
        if self.fresh or self.factors is None:
            self._average(P)
            self._averaged = self._diagonal.copy()
            self.averaged_mean, change = self._diagonal.sum() / size, 0.0  # the shift, and the operator's scale
        else:  # the same values, another shift: its change entry by entry (exact but for the shifts' round-off)
            self._diagonal.axpy(-1.0, self._averaged)
            change = self._diagonal.sum() / size
            if abs(change - self.factored_change) <= LAG * abs(self.averaged_mean + self.factored_change):
                return  # the factors of a nearby shift precondition as well
        self.factors.factor(1.0, change)  # (the shift's change) I + (the average as averaged)
        self.factored_change = change
        self.n_factors += 1

    def _set_up_newton(self, newton):
        """As :meth:`setUp`, P the engine's Newton matrix (weight J + diagonal I, the two numbers
        and the assembled J: :class:`~icidr_pde.engines.petsc.NewtonMatrix`): J averaged where new,
        the factors of weight (the average) + diagonal I, kept while the mean of the diagonal
        stays within :data:`LAG` of theirs."""
        J = newton.jacobian
        averaged = self.fresh or self.factors is None
        if averaged:
            self._average(J)
            if self._diagonal is None:
                self._diagonal = J.createVecLeft()
            J.getDiagonal(self._diagonal)
            self.jacobian_mean = self._diagonal.sum() / self._diagonal.getSize()
        weight, diagonal = newton.weight, newton.diagonal
        mean = weight * self.jacobian_mean + diagonal
        if not averaged and weight == self.factored_weight and abs(mean - self.factored_mean) <= LAG * abs(
                self.factored_mean):
            return  # the factors of a nearby shift precondition as well
        self.factors.factor(weight, diagonal)
        self.factored_weight, self.factored_mean = weight, mean
        self.n_factors += 1

    def _average(self, P):
        """The x-average of this rank's rows of P, gathered on every rank, and its factors' set-up."""
        PETSc = self.PETSc
        indptr, indices, data = P.getValuesCSR()
        start = P.getOwnershipRange()[0]
        self.local_average[...] = 0.0
        outside = rows_average(indptr, indices, data, start, self.dof, self.nx, self.dof * self.zs,
                               self.local_average)
        if outside:
            raise ValueError(f"{outside} couplings of the matrix reach beyond the stencil the x-Fourier "
                             f"preconditioner was set up for (band {self.band}, x-offsets {self.reach})")
        self._mine.setArray(self.local_average.reshape(-1))
        self._gather.scatter(self._mine, self._all, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        average = np.array(self._all.getArray(readonly=True)).reshape(self.m * (2 * self.band + 1), -1)
        self.factors = XFourierFactors(average, self.nx, self.band, self.reach, self.modes)
        self.fresh = False
        self.n_averages += 1

    def apply(self, pc, x, y):
        """y = the preconditioner's inverse of x: FFT in x, transpose, banded solves, back."""
        PETSc = self.PETSc
        shape = (self.ze - self.zs, self.nx, self.dof)
        spectrum = self.spectrum.getArray().view(np.complex128).reshape(shape[0], -1, self.dof)
        np.fft.rfft(x.getArray(readonly=True).reshape(shape), axis=1, out=spectrum)  # (z, k, field), this rank's
        self.transpose.scatter(self.spectrum, self.columns, addv=PETSc.InsertMode.INSERT,
                               mode=PETSc.ScatterMode.FORWARD)
        columns = self.columns.getArray().view(np.complex128).reshape(len(self.modes), self.m)
        self.factors.solve(columns)  # in the vector's own memory
        self.transpose.scatter(self.columns, self.spectrum, addv=PETSc.InsertMode.INSERT,
                               mode=PETSc.ScatterMode.REVERSE)
        spectrum = self.spectrum.getArray(readonly=True).view(np.complex128).reshape(shape[0], -1, self.dof)
        np.fft.irfft(spectrum, n=self.nx, axis=1, out=y.getArray().reshape(shape))
