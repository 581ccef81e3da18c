"""GMRES preconditioned by the exact inverse of I - gamma A, A the x-average of the analytic
sparse Jacobian of the x-periodic 2-D cell (:mod:`.xfourier_inverse`): the 2-D default on CVODE
(:class:`XFourierGmres`) and on PETSc (:class:`PetscXFourier`, the same inverse inside PETSc's KSP
on the ranks of the grid, :mod:`.xfourier_shell`)."""

from __future__ import annotations

from .gmres import PetscGmres, Preconditioned

__all__ = ["XFourierGmres", "PetscXFourier", "FOURIER_BYTES"]

#: the x-Fourier preconditioner ('fourier'), per unknown beyond the scheme's estimate: the banded LU
#: factors of the Nx / 2 + 1 wave numbers (complex: 417 bytes a cell, with 8 % to spare); one block
#: of its x-average (:mod:`.x_average`) is counted apart (:meth:`XFourierGmres.memory`). The whole
#: process grew by 1.55 kB a cell from 256^2 to 512^2 with it (docs/scaling.md, the memory section)
FOURIER_BYTES = 450.0 / 3


class XFourierGmres(Preconditioned):
    """GMRES, Jacobian-vector products by difference quotients with a small increment
    (:mod:`..jacobian_vector`), left-preconditioned by the inverse of I - gamma A."""

    name = "GMRES + x-Fourier preconditioner"
    modes = ("fourier",)
    preference = 60
    what = "the x-average of the Jacobian, FFT in x"
    default = True
    bytes_per_unknown = FOURIER_BYTES
    memory_note = "the banded LU factors of the x-Fourier preconditioner and one block of its x-average"

    def memory(self, n, method, mode, thin=False):
        from .base import Memory
        from .x_average import block_bytes

        return Memory(self.bytes_per_unknown * n + block_bytes(n // 3), self.memory_note, repr(mode))

    def jacobian_spec(self, pde, state, mode):
        if not state.grid.periodic[0]:
            from ...validation import ParameterError

            raise ParameterError("`jacobian`='fourier' needs a grid periodic in x (the 2-D cell); use 'amg' or "
                                 "'krylov'")
        spec = super().jacobian_spec(pde, state, mode)
        if getattr(pde, "patches", None) is None:
            return spec
        from dataclasses import replace

        from .x_average import XAverage

        # the average by blocks of x-columns: the whole Jacobian's ~3.2 kB a cell are never held
        return replace(spec, jac=None, x_average=XAverage(pde.patches(state)))

    def preconditioner(self, problem):
        from .xfourier_inverse import xfourier_preconditioner

        jacobian = problem.jacobian
        return xfourier_preconditioner(jacobian.jac, jacobian.shape, jacobian.weights, jacobian.x_average)

    def jactimes(self, problem):
        from ..jacobian_vector import difference_jtimes
        from .base import fun_into

        return difference_jtimes(fun_into(problem), len(problem.y0))


class PetscXFourier(PetscGmres):
    """PETSc's Newton-Krylov preconditioned by the x-Fourier inverse of its assembled matrix (shift
    I - J): a shell preconditioner (:class:`~.xfourier_shell.XFourierShell`) on a grid split
    along z only, so that each rank's FFT in x is its own. Where the problem brings no grid
    (:class:`~icidr_pde.engines.petsc.BlockGrid`) or ``-pc_type`` asks for another, the engine
    takes PETSc's preconditioner instead."""

    name = "PETSc TS bdf + SNES newtonls + KSP gmres + PC x-Fourier"
    modes = ("sparse",)
    preference = 60
    petsc = ("gmres", "x-Fourier")
    #: PETSc's options of this solver over the engine's defaults (-pc_type, -ksp_rtol override them):
    #: the shell preconditioner, and GMRES to 1e-2 of the preconditioned residual, as loose as
    #: CVODE's (0.05 of Newton's tolerance): with an inverse this close the Newton iterations and the
    #: numbers are those of 1e-8 (bump2d 128^2 to t = 10: max|w| within 1e-8 relative, the same steps),
    #: at a third of the preconditioner's applications (docs/distributed.md)
    petsc_options = {"pc_type": "python", "ksp_rtol": 1e-2}

    def offered(self, mode, structure):
        return structure.amg and structure.advected  # fields on a 2-D grid periodic along x

    def proc_sizes(self, ranks: int) -> tuple[int, int]:
        """The DMDA's ranks along (x, z): along z only."""
        return (1, ranks)

    def shell(self, PETSc, grid):
        """The PC context of `grid` (a :class:`~icidr_pde.engines.petsc.BlockGrid`)."""
        from .xfourier_shell import XFourierShell

        return XFourierShell(PETSc, grid.da, grid.patches.stencil)
