"""GMRES preconditioned along the walls' normal in a thin 2-D cell: the line preconditioner."""

from __future__ import annotations

from .base import JacobianForm, Memory
from .gmres import Gmres

__all__ = ["LineGmres", "line_preconditioner", "LINE_BYTES"]

#: the line preconditioner of a thin 2-D cell's GMRES (mode 'krylov' where hx > THIN_CELL hz), per
#: unknown beyond the scheme's estimate: at its set-up the analytic sparse Jacobian, its restriction
#: to the couplings along z and I - gamma J_line, SuperLU's factors (C memory tracemalloc does not
#: see, counted from their entries) and the line pattern, measured by benchmarks/line_memory.py and
#: taken with 10 % to spare; without it a thin cell's estimate fell far below its peak
#: (docs/scaling.md, the memory section)
LINE_BYTES = 1_400.0


class LineGmres(Gmres):
    """GMRES on a scheme that gives a line pattern where its cell is thin (the 2-D cell's
    ``line_pattern``): preconditioned there by :func:`line_preconditioner`, unpreconditioned
    on a thick cell (no pattern)."""

    name = "GMRES (line preconditioner in thin cells)"
    modes = ("krylov",)
    preference = 30
    form = JacobianForm("matrix-free", ("jac", "line_pattern", "weights", "anchor"))
    petsc = ("gmres", "bjacobi")

    def offered(self, mode, structure):
        return structure.line

    def memory(self, n, method, mode, thin=False):
        if not thin:
            return Memory(0.0, "", repr(mode))
        return Memory(LINE_BYTES * n, "the analytic sparse Jacobian and the SuperLU factors of the line "
                      "preconditioner of a thin cell", "'krylov' (GMRES with the line preconditioner)")

    def preconditioner(self, problem):
        jacobian = problem.jacobian
        if jacobian.line_pattern is None:
            return None
        return line_preconditioner(jacobian.jac, jacobian.line_pattern, jacobian.weights, jacobian.anchor)

    def set_up_name(self, options):
        return "GMRES + line preconditioner" if "precond" in options else "GMRES"


def line_preconditioner(jac, pattern, weights=None, anchor=None):
    """CVODE's left preconditioner P = I - gamma J_line: the analytic Jacobian restricted to
    `pattern` (the couplings along z of a thin 2-D cell, :meth:`ShearCell2DPDE.line_pattern`),
    factored by SuperLU; J_line is re-evaluated when CVODE asks for a new Jacobian, P whenever
    gamma changes. With the mass weights c and `anchor` (:meth:`StiffSolver._conserved`) each
    column's dropped mass-row entries are added to its anchor row, so that c P = c and the
    preconditioned Newton corrections keep the mass. Without it GMRES(20) cannot solve the
    Newton systems of a thin cell: bump2d 32^2 at H = 0.01 (L = 30) failed at t = 2e-3 with
    h = 7e-9; at H = 0.3 it took 2814 steps (156 preconditioned). What it holds and what its set-up
    allocates is in the memory check of the run (:data:`LINE_BYTES`)."""
    import numpy as np
    from scipy import sparse
    from scipy.sparse.linalg import splu
    from sksundae.cvode import CVODEPrecond

    keep = sparse.csc_matrix(pattern, dtype=float)
    keep.data[:] = 1.0
    n = keep.shape[0]
    eye = sparse.identity(n, format="csc")
    saved = {}

    def line_jacobian(t, y):
        J = sparse.csc_matrix(jac(t, np.array(y))).multiply(keep).tocsc()
        if weights is None:
            return J
        lost = -(weights @ J)  # the dropped part of each column's mass row sum (c J = 0)
        return (J + sparse.csc_matrix((lost / weights[anchor], (anchor, np.arange(n))), shape=(n, n))).tocsc()

    def setup(t, y, yp, jok, jnew, gamma):
        if not jok or "J" not in saved:
            saved["J"] = line_jacobian(t, y)
            jnew[0] = 1
        else:
            jnew[0] = 0
        saved["lu"] = splu((eye - gamma * saved["J"]).tocsc())

    def solve(t, y, yp, r, z, gamma, delta, lr):
        z[:] = saved["lu"].solve(np.array(r))

    return CVODEPrecond(setup, solve, side="left")
