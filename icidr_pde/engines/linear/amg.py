"""GMRES preconditioned by one algebraic-multigrid V-cycle (:mod:`.amg_hierarchy`)."""

from __future__ import annotations

from .gmres import Preconditioned

__all__ = ["AmgGmres", "AMG_BYTES"]

#: the algebraic-multigrid path ('amg'), per unknown beyond the scheme's estimate: the analytic
#: Jacobian, its node-major copy, the level operators and pyamg's set-up temporaries: 7.2 kB a 2-D
#: cell, from the peak memory with and without it (docs/scaling.md, the memory section)
AMG_BYTES = 7_200.0 / 3


class AmgGmres(Preconditioned):
    """GMRES, Jacobian-vector products by CVODE's difference quotients, left-preconditioned by one
    algebraic-multigrid V-cycle on I - gamma J of the analytic sparse Jacobian, aggregated by
    the cells' blocks of fields."""

    name = "GMRES + AMG preconditioner"
    modes = ("amg",)
    preference = 50
    what = "algebraic multigrid"
    bytes_per_unknown = AMG_BYTES
    memory_note = "the analytic sparse Jacobian and the algebraic-multigrid hierarchy"
    petsc = ("gmres", "gamg")

    def preconditioner(self, problem):
        from .amg_hierarchy import amg_preconditioner

        jacobian = problem.jacobian
        return amg_preconditioner(jacobian.jac, jacobian.fields, jacobian.weights)
