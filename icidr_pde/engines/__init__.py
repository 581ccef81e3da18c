"""Integration engines: one protocol, one choice, one engine per module.

* :mod:`.base` -- the contracts: :class:`~.base.Problem` (what an engine integrates, without
  py-pde, scheme or case), :class:`~.base.Engine` (scipy's ``OdeSolver`` style),
  :class:`~.base.JacobianSpec`, :class:`~.base.StepStatistics`, :class:`~.base.SimulationFailed`;
* :mod:`.choose` -- :func:`~.choose.choose`: engine, Jacobian and linear solver of a run, with
  the reason where the native engine was asked for and not taken;
* :mod:`.scipy` (scipy's BDF, Radau, LSODA), :mod:`.sundae` (SUNDIALS CVODE through
  scikit-sundae), :mod:`.native` (CVODE on the compiled C problem of :mod:`icidr_pde.native`,
  many output times per call into C), :mod:`.petsc` (PETSc's TS, SNES, KSP over MPI; the
  ``[petsc]`` extra);
* :mod:`.linear` -- the linear solvers of the Newton systems and their preconditioners, one
  registered object each (:class:`~.linear.LinearSolver`): the Jacobian modes of the methods
  below are theirs;
* :mod:`.stiff` -- :class:`~.stiff.StiffSolver`, py-pde's solver "stiff" over these engines
  (the README's ``pde.solve(state)`` idiom);
* helpers: :mod:`.colored_fd`, :mod:`.conservative_jacobian`, :mod:`.cvode_counters`,
  :mod:`.state_bounds`; below them :mod:`icidr_pde.time_scale` and :mod:`icidr_pde.cvode_settings`, which the
  compiled problems of :mod:`icidr_pde.native` share with the engines.

This module, :mod:`.choose` and the registry of :mod:`.linear` are light (no scipy, numba, py-pde or scikit-sundae): a warm
native run imports them; each engine's module is loaded by :func:`engine_class` when used.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import import_module

from .linear import SOLVERS, jacobian_modes

__all__ = ["ENGINES", "EngineEntry", "METHODS", "JACOBIAN_MODES", "engine_class"]


@dataclass(frozen=True)
class EngineEntry:
    """An engine of the registry: where its class is, and the Jacobian modes of each of its
    methods (the first: the method's default)."""

    module: str
    cls: str
    jacobian_modes: dict

    @property
    def methods(self) -> tuple[str, ...]:
        return tuple(self.jacobian_modes)


#: engine name -> where it is and what it integrates (the names a run's settings give)
ENGINES = {
    "scipy": EngineEntry("scipy", "ScipyEngine", {m: jacobian_modes(m) for m in ("BDF", "Radau", "LSODA")}),
    "sundae": EngineEntry("sundae", "CvodeEngine", {"CVODE": jacobian_modes("CVODE")}),  # its linear solvers' modes
    "native": EngineEntry("native", "NativeEngine", {"CVODE": ("analytic",)}),
    "petsc": EngineEntry("petsc", "PetscEngine", {"PETSC-BDF": ("sparse",)}),
}
#: every method a run can take, each by the first engine above that has it
METHODS = tuple(dict.fromkeys(m for entry in ENGINES.values() for m in entry.methods))
#: every Jacobian mode a run may ask for: scipy's first, then CVODE's, then any other linear solver's (:mod:`.linear`)
JACOBIAN_MODES = tuple(dict.fromkeys(("analytic", "sparse-fd", "banded-fd", "colored-fd") + jacobian_modes("CVODE")
                                     + tuple(m for s in SOLVERS for m in s.modes)))


def engine_class(name: str):
    """The class of engine `name` (its module imported now)."""
    entry = ENGINES[name]
    return getattr(import_module(f".{entry.module}", __name__), entry.cls)
