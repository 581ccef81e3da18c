"""GMRES on the Newton systems, matrix-free (CVODE's difference quotients of J v), and the
base of the preconditioners built from the analytic sparse Jacobian of a 2-D grid."""

from __future__ import annotations

from ...cvode_settings import KRYLOV_DIM
from .base import JacobianForm, LinearSolver, Memory, cell_mass

__all__ = ["Gmres", "Preconditioned", "CompiledGmres", "PetscGmres"]


class Gmres(LinearSolver):
    """GMRES without a preconditioner, Jacobian-vector products by CVODE's difference quotients.
    On iCIDR bump2d it is far faster than SuperLU_MT with the analytic Jacobian ('sparse'; the
    times: docs/sim2d.md)."""

    name = "GMRES"
    modes = ("krylov",)
    methods = ("CVODE",)
    preference = 40
    form = JacobianForm("matrix-free")
    krylov = True
    petsc = ("gmres", "none")

    def cvode_options(self, problem, rtol, atol):
        kwargs = dict(linsolver="gmres", krylov_dim=KRYLOV_DIM)
        precond = self.preconditioner(problem)
        if precond is not None:
            kwargs["precond"] = precond
        jactimes = self.jactimes(problem)
        if jactimes is not None:
            kwargs["jactimes"] = jactimes
        return kwargs

    def preconditioner(self, problem):
        """scikit-sundae's CVODEPrecond of `problem`, or None."""
        return None

    def jactimes(self, problem):
        """scikit-sundae's Jacobian-vector product of `problem`, or None (CVODE's difference quotients)."""
        return None


class Preconditioned(Gmres):
    """GMRES left-preconditioned by an approximate inverse of I - gamma J built from the
    analytic sparse Jacobian of a 2-D grid (the structure's ``amg``): a subclass that names
    itself (``name``), its Jacobian mode (``modes``), what preconditions (`what`), its memory per
    unknown (`bytes_per_unknown`, holding `memory_note`) and :meth:`preconditioner` is registered
    and chosen where its mode is asked for."""

    what = ""
    #: the mode 'auto' takes on a thick cell that offers it (the x-Fourier preconditioner's)
    default = False
    bytes_per_unknown = 0.0
    memory_note = ""
    form = JacobianForm("matrix-free", ("jac", "weights", "fields", "shape"))

    def offered(self, mode, structure):
        return structure.amg

    def refusal(self, mode: str, valid, schemes=()) -> str:
        """Why `mode` is refused on a scheme without what this preconditioner is built from
        (`schemes`: the registered schemes that offer it, if known)."""
        which = f" (discretization {' or '.join(schemes)})" if schemes else ""
        return (f"`jacobian`={mode!r} (GMRES preconditioned by {self.what}) needs the analytic sparse Jacobian of "
                f"a 2-D grid{which}; use " + ("'krylov' or 'analytic'" if "krylov" in valid else "'analytic'"))

    def memory(self, n, method, mode, thin=False):
        return Memory(self.bytes_per_unknown * n, self.memory_note, repr(mode))

    def jacobian_spec(self, pde, state, mode: str):
        """The :class:`~icidr_pde.engines.base.JacobianSpec` it is built from: the analytic sparse
        Jacobian, the mass weights, the fields per cell and the shape of the unknowns."""
        from ..base import JacobianSpec

        return JacobianSpec(mode, jac=pde.make_jacobian(state), weights=cell_mass(state),
                            fields=state.data.shape[0], shape=state.data.shape)


class CompiledGmres(LinearSolver):
    """GMRES of a compiled problem (:mod:`icidr_pde.native`), preconditioned as its C code says
    (`preconditioner`: 'band', 'dense', or '' for none)."""

    methods = ("CVODE",)
    engine = "native"
    form = JacobianForm("matrix-free")
    krylov = True

    def __init__(self, preconditioner: str = ""):
        self.preconditioner = preconditioner

    @property
    def name(self) -> str:
        return f"GMRES + {self.preconditioner} preconditioner" if self.preconditioner else "GMRES"


#: the PETSc engine's peak per unknown beyond the 2-D scheme's 2.5 kB a cell, all ranks together:
#: 8.5-11 kB a cell measured at 512^2 and 1024^2 on 1-4 ranks (docs/distributed.md, memory per rank)
PETSC_BYTES = (9_000.0 - 2_500.0) / 3


class PetscGmres(LinearSolver):
    """PETSc's Newton-Krylov on the analytic sparse Jacobian (:mod:`..petsc`): GMRES preconditioned
    by block Jacobi with ILU in the blocks, its defaults; its options may change both."""

    methods = ("PETSC-BDF",)
    engine = "petsc"
    form = JacobianForm("sparse")
    krylov = True
    petsc = ("gmres", "bjacobi")

    @property
    def name(self) -> str:
        return "PETSc TS bdf + SNES newtonls + KSP {} + PC {}".format(*self.petsc)

    def memory(self, n, method, mode, thin=False):
        # all ranks together (each holds its own block): the matrix, its COO maps, the ILU blocks,
        # the Krylov basis and the Jacobian's evaluation, beyond the scheme's estimate
        return Memory(PETSC_BYTES * n, "PETSc's matrix, ILU blocks and Krylov basis, all ranks", repr(mode))
