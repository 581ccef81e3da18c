"""The ranks of a command started by an MPI launcher (``mpiexec -n P icidr-pde ...``, ``srun``):
which one speaks and writes, and what they agree on.

Every rank runs the same command and computes (the PETSc engine divides each run among them);
rank 0 alone prints (progress, results, errors) and writes the outputs, the others write
nothing. The rules, all kept here:

- *who is rank 0*: the rank the launcher put in the environment (:func:`launcher_rank`), readable
  before MPI starts (argparse's errors come first) and the same as MPI's COMM_WORLD rank;
- *rank 0 speaks*: :func:`root_speaks` sends the other ranks' standard output and error to
  ``os.devnull`` for the command (an error that escapes it is still shown: the streams are back
  before the interpreter prints a traceback);
- *rank 0 writes*: :func:`writes_here` is what :mod:`icidr_pde.outputs` asks before it installs
  a file (the other ranks write to a temporary file that is removed), so every output of every
  command, written atomically there, is rank 0's alone;
- *a failure on any rank reaches all ranks*: a check that depends on the rank's file system
  (an output's folder) is made by rank 0 and its verdict agreed (:func:`same_verdict`), the
  cases a study takes from its cache are those every rank found (:func:`everywhere`), and the
  command's exit status is the largest of the ranks' (:func:`agree`), so that a write that
  failed on rank 0 (4) or an interrupt (130, 143) is every rank's status.

The ranks talk through PETSc's COMM_WORLD (petsc4py: the MPI the engine runs on; mpi4py is not
needed), started here when the launcher says there are several processes. Without a launcher,
with one process, or where PETSc cannot start (petsc4py missing, another MPI's launcher), every
function here is that of a single process: it speaks, writes and agrees with itself.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys

__all__ = ["RANK_VARIABLES", "launcher_rank", "launched", "speaks", "writes_here", "ranks", "root_speaks",
           "gathered", "agree", "everywhere", "same_verdict"]

#: the rank an MPI launcher gives this process (Open MPI, MPICH/Hydra, PMIx, Slurm's srun)
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "SLURM_PROCID")
#: the number of processes it started (srun: the job step's tasks)
SIZE_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS")


def _first_number(names) -> int | None:
    for name in names:
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return None


def launcher_rank() -> int:
    """This process's rank as its MPI launcher set it in the environment (0 outside one), read
    before MPI is started (the command line's own errors)."""
    return _first_number(RANK_VARIABLES) or 0


def launched() -> int:
    """How many processes the launcher started (1 outside one)."""
    return max(_first_number(SIZE_VARIABLES) or 1, 1)


def speaks() -> bool:
    """Whether this process prints: rank 0, or a process without a launcher."""
    return launcher_rank() == 0


def writes_here() -> bool:
    """Whether this process installs the files it writes (rank 0 alone)."""
    return launcher_rank() == 0


@functools.cache
def _world():
    """petsc4py's PETSc with MPI started, where the launcher started several processes that PETSc
    sees as one COMM_WORLD; else None (one process, no petsc4py, or another MPI's launcher)."""
    if launched() < 2:
        return None
    from .engines.petsc import _petsc

    try:
        PETSc = _petsc()
    except ImportError:  # the PETSc engine says why, in one line, if the command asks for it
        return None
    return PETSc if PETSc.COMM_WORLD.size > 1 else None


def ranks() -> int:
    """The number of ranks that agree (1: this process alone)."""
    world = _world()
    return 1 if world is None else world.COMM_WORLD.size


def gathered(values):
    """(ranks, m): the m numbers each rank gives, on every rank (collective: every rank calls it
    with the same m). One rank: its own, as one row."""
    import numpy as np

    values = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
    PETSc = _world()
    if PETSc is None:
        return values[None, :]
    if values.size == 0:
        return np.empty((PETSc.COMM_WORLD.size, 0))
    mine = PETSc.Vec().createMPI((values.size, None), comm=PETSc.COMM_WORLD)
    mine.setArray(values)
    scatter, full = PETSc.Scatter.toAll(mine)
    try:
        scatter.scatter(mine, full, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return np.array(full.getArray(readonly=True)).reshape(PETSc.COMM_WORLD.size, values.size)
    finally:
        for obj in (scatter, full, mine):
            obj.destroy()


def agree(status: int) -> int:
    """The largest exit status of the ranks, on every rank (collective)."""
    return int(gathered([status]).max())


def everywhere(flags):
    """For each flag, whether every rank has it (collective)."""
    import numpy as np

    flags = np.asarray(flags, dtype=bool)
    return gathered(flags).min(axis=0).astype(bool).reshape(flags.shape) if flags.size else flags


def same_verdict(check, refusal: type[Exception] = ValueError):
    """``check()`` on rank 0 and its verdict on every rank (collective): what it returns, or the
    exception it raises, raised on every rank (the other ranks, which say nothing, raise
    `refusal`). For checks of the file system rank 0 writes to, which another rank may not see
    alike (another node's mounts)."""
    if _world() is None:
        return check()
    error, out = None, None
    if writes_here():
        try:
            out = check()
        except Exception as err:  # noqa: BLE001 - every kind goes to the other ranks as a failure
            error = err
    if agree(error is not None):
        raise error if error is not None else refusal("refused on rank 0 (which says why)")
    return out


@contextlib.contextmanager
def root_speaks():
    """For the block: on a rank other than 0, standard output and error go to ``os.devnull``
    (print, progress bars, warnings); back as they were after it, whatever happens in it."""
    if speaks():
        yield
        return
    saved = sys.stdout, sys.stderr
    with open(os.devnull, "w") as sink:
        sys.stdout = sys.stderr = sink
        try:
            yield
        finally:
            sys.stdout, sys.stderr = saved
