"""The linear solvers of the Newton systems and their preconditioners, one module each, in the
registry :data:`~.base.SOLVERS` that :func:`~icidr_pde.engines.choose.choose` walks.

* :mod:`.base` -- :class:`~.base.LinearSolver` (Jacobian form, where it applies, memory, name,
  CVODE's options) and the registry;
* :mod:`.dense_lu`, :mod:`.band_lu`, :mod:`.sparse_lu` -- the direct solvers;
* :mod:`.gmres` -- GMRES and the base of its preconditioners: :mod:`.line` (thin cells),
  :mod:`.amg` (algebraic multigrid, :mod:`.amg_hierarchy`, :mod:`.amg_kernels`), :mod:`.xfourier`
  (the x-averaged Jacobian, :mod:`.xfourier_inverse`); :mod:`.precond` wraps a preconditioner for
  CVODE and keeps the mass.

A preconditioner is one module: a :class:`~.gmres.Preconditioned` subclass, imported here.
Light: the solvers' own libraries are imported when a solver is set up.
"""

from . import amg, band_lu, dense_lu, gmres, line, sparse_lu, xfourier  # noqa: F401  (each registers its solvers)
from .base import SOLVERS, LinearSolver, Memory, jacobian_modes, named, solver_for, unregister

__all__ = ["SOLVERS", "LinearSolver", "Memory", "jacobian_modes", "named", "solver_for", "unregister",
           "compiled_solver"]


def compiled_solver(kind: str, preconditioner: str = "", solver: str = "") -> LinearSolver:
    """The linear solver a compiled problem (:mod:`icidr_pde.native`) set up: `kind` 'krylov'
    (GMRES + `preconditioner`), 'gmres' (GMRES, none), 'dense' (its dense LU, LAPACK's where
    `solver` is 'lapack') or 'band' (CVODE's band LU on its analytic band Jacobian)."""
    if kind == "band":
        return band_lu.CvodeBandLU()
    if kind == "krylov":
        return gmres.CompiledGmres(preconditioner)
    if kind == "gmres":
        return gmres.CompiledGmres()
    if kind == "dense":
        return dense_lu.CvodeDenseLU() if solver == "lapack" else dense_lu.CvodeDenseQuotients()
    raise ValueError(f"a compiled problem's linear solver is 'band', 'krylov', 'gmres' or 'dense'; got {kind!r}")
