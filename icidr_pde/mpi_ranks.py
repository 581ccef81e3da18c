"""The ranks of a command started by an MPI launcher (``mpiexec -n P icidr-pde ...``, ``srun``):
which one speaks and writes, and what they agree on.

Every rank runs the same command and computes (the PETSc engine divides each run among them);
rank 0 alone prints (progress, results, errors) and writes the outputs, the others write
nothing. The rules, all kept here:

- *who is rank 0*: the rank the launcher put in the environment (:func:`launcher_rank`), readable
  before MPI starts (argparse's errors come first) and the same as MPI's COMM_WORLD rank; once
  PETSc is started, COMM_WORLD's rank (:func:`rank`);
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
  failed on rank 0 (4) or an interrupt (130, 143) is every rank's status; what rank 0 alone
  knows reaches the others by :func:`broadcast`, a bound of the ranks' numbers by
  :func:`reduce_max`;
- *an uncaught exception on one rank ends every rank*: the others would wait for it in their next
  collective, and it in MPI_Finalize for them. Where the ranks start (here, or the PETSc engine),
  :func:`abort_on_uncaught` installs a ``sys.excepthook`` that prints the traceback as Python
  does and calls MPI_Abort on COMM_WORLD (mpi4py's ``python -m mpi4py`` does the same);
- *signals at agreed points*: SIGINT and SIGTERM (mpiexec sends them to every rank, each in its
  own place) are noted, not raised where they land (:func:`defer`, :func:`noting_signals`): a rank
  leaving alone would leave the others waiting in its collectives. Every rank raises the largest
  noted signal at the same point (:func:`deliver`): after a step of the PETSc engine (its per-step
  reduction carries :func:`pending`) and after each case of a study (:func:`at_agreed_point`), from
  where the serial path keeps what was computed.

The ranks talk through PETSc's COMM_WORLD (petsc4py: the MPI the engine runs on; mpi4py is not
needed), started here when the launcher says there are several processes. Once PETSc is started
(here or by the engine), its COMM_WORLD says how many ranks agree, whatever the launcher's
variables say (a launcher that sets none of those read here). Without a launcher, with one
process, or where PETSc cannot start (petsc4py missing, another MPI's launcher), every function
here is that of a single process: it speaks, writes and agrees with itself.
"""

from __future__ import annotations

import contextlib
import functools
import os
import pickle
import signal
import sys
import threading

__all__ = ["RANK_VARIABLES", "launcher_rank", "launched", "speaks", "writes_here", "ranks", "rank", "root_speaks",
           "gathered", "broadcast", "reduce_max", "agree", "everywhere", "same_verdict", "defer", "pending", "deliver",
           "noting_signals", "at_agreed_point", "abort_on_uncaught", "SIGNALS"]

#: the signals that stop a run and keep what it computed
SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: the rank an MPI launcher gives this process (Open MPI, MPICH/Hydra, PMIx, Slurm's srun), the
#: first set read, in the order of SIZE_VARIABLES (a rank and a number of one launcher)
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "SLURM_PROCID")
#: the number of processes it started, the first set read (:func:`launched`). What each launcher
#: sets: Open MPI's mpiexec OMPI_COMM_WORLD_SIZE (and PMIX_RANK; PMIx has no variable of the size);
#: MPICH's Hydra PMI_SIZE; Slurm's srun SLURM_STEP_NUM_TASKS for every task, with PMI_SIZE (the
#: same number) under --mpi=pmi2, PMIX_RANK under --mpi=pmix, no MPI variable under --mpi=none.
#: The MPI launcher's variable comes before Slurm's because Slurm's are leftovers wherever an
#: mpiexec runs inside a Slurm step (an `srun --pty` shell) or starts its daemons through srun
#: (Open MPI's and Hydra's across the nodes of an allocation: a step of one task per node), and
#: the first set, not the largest, because a leftover's number may be the larger. SLURM_NTASKS is
#: not read: a batch script, one process, has the job's tasks there. A leftover variable of an
#: MPI read before the launcher's own (Open MPI's around MPICH's mpiexec) would still win: once
#: PETSc is started, its COMM_WORLD says how many ranks agree (:func:`ranks`), whatever this says.
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
    """How many processes the launcher that started this one started (1 outside one), read before
    MPI is started: the first of :data:`SIZE_VARIABLES` that is set. It decides whether MPI is
    started here, and the PETSc engine refuses a run of one rank where it says several (their
    launcher's processes do not see each other)."""
    return max(_first_number(SIZE_VARIABLES) or 1, 1)


def speaks() -> bool:
    """Whether this process prints: rank 0, or a process without a launcher."""
    return launcher_rank() == 0


def writes_here() -> bool:
    """Whether this process installs the files it writes (rank 0 alone)."""
    return rank() == 0


def _world():
    """petsc4py's PETSc with MPI started, where this process is one of several ranks of PETSc's
    COMM_WORLD; else None (one process, no petsc4py, or another MPI's launcher). Once PETSc is
    started (here or by the engine) its communicator says, whatever the launcher's variables say:
    a launcher that sets none of those read here still has its ranks agree."""
    PETSc = sys.modules.get("petsc4py.PETSc")  # imported: PETSc and MPI are started
    if PETSc is not None:
        if PETSc.COMM_WORLD.size < 2:
            return None
        abort_on_uncaught()
        return PETSc
    return _started_here()


@functools.cache
def _started_here():
    """_world() where PETSc is not started yet: it is started here where the launcher says there
    are several processes."""
    if launched() < 2:
        return None
    from . import loaded_mpi

    if loaded_mpi.loaded():  # another MPI here: PETSc's would abort
        return None
    try:
        PETSc = start_petsc()
    except ImportError:  # the PETSc engine says why, in one line, if the command asks for it
        return None
    abort_on_uncaught()
    return PETSc if PETSc.COMM_WORLD.size > 1 else None


#: PETSc's BLAS threads per rank where the environment sets none (PETSc reads these variables
#: itself when it starts; docs/distributed.md measures the difference)
BLAS_THREADS = 1
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")


def start_petsc():
    """petsc4py's PETSc, started (MPI_Init and PETSc's options) by whoever asks first: here, the
    engine or a study; ImportError without petsc4py. Its options are set only at the start: PETSc's
    BLAS on :data:`BLAS_THREADS` thread where the environment names no count (its vector
    operations call OpenBLAS, whose own count, one thread per core, took about 10x their time on
    a loaded machine, and on P ranks would put P threads on each core)."""
    if "petsc4py.PETSc" not in sys.modules and not any(os.environ.get(name) for name in BLAS_THREAD_VARIABLES):
        import petsc4py

        petsc4py.init(["-blas_num_threads", str(BLAS_THREADS)])
    from petsc4py import PETSc

    return PETSc


def abort_on_uncaught() -> None:
    """From now on, an exception that reaches the top of this process prints its traceback (the
    hook that was there, Python's own) and, where PETSc runs with several ranks, ends every rank:
    MPI_Abort on COMM_WORLD, status 1 (130 for KeyboardInterrupt). Installed once."""
    if getattr(sys.excepthook, "ends_every_rank", False):
        return
    previous = sys.excepthook

    def hook(kind, value, traceback):
        previous(kind, value, traceback)
        PETSc = sys.modules.get("petsc4py.PETSc")
        if PETSc is None or PETSc.Sys.isFinalized() or PETSc.COMM_WORLD.size < 2:
            return
        for stream in (sys.stdout, sys.stderr):  # MPI_Abort ends the process without Python's flush
            with contextlib.suppress(Exception):
                stream.flush()
        _mpi_abort(PETSc, 130 if issubclass(kind, KeyboardInterrupt) else 1)

    hook.ends_every_rank = True
    sys.excepthook = hook


def _mpi_abort(PETSc, code: int) -> None:
    """MPI_Abort(COMM_WORLD, code) of PETSc's MPI (petsc4py has no abort; mpi4py is not required):
    the function looked up from petsc4py's extension, whose libraries hold PETSc's MPI. Where it
    cannot be found, the process ends with `code` and the launcher ends the others (Open MPI's
    mpiexec and MPICH's Hydra do; Slurm's srun with --kill-on-bad-exit)."""
    import ctypes

    try:
        mpi = ctypes.CDLL(PETSc.__file__)
        comm = PETSc.COMM_WORLD.fortran
        try:  # Open MPI: a C handle is a pointer, from the Fortran integer
            f2c = mpi.MPI_Comm_f2c
            f2c.restype, f2c.argtypes = ctypes.c_void_p, [ctypes.c_int]
            mpi.MPI_Abort.argtypes = [ctypes.c_void_p, ctypes.c_int]
            comm = f2c(comm)
        except AttributeError:  # MPICH: MPI_Comm_f2c is a macro, the C handle the Fortran integer
            mpi.MPI_Abort.argtypes = [ctypes.c_int, ctypes.c_int]
        mpi.MPI_Abort(comm, code)
    finally:
        os._exit(code)


def ranks() -> int:
    """The number of ranks that agree (1: this process alone)."""
    world = _world()
    return 1 if world is None else world.COMM_WORLD.size


def rank() -> int:
    """This process's rank: PETSc's COMM_WORLD's where PETSc is started with several ranks, else
    the launcher's (:func:`launcher_rank`). Does not start MPI."""
    PETSc = sys.modules.get("petsc4py.PETSc")
    if PETSc is not None and PETSc.COMM_WORLD.size > 1:
        return PETSc.COMM_WORLD.rank
    return launcher_rank()


def _to_all(PETSc, values):
    """Every rank's `values` (float, any number on each rank), rank after rank, on every rank
    (collective): one vector of theirs scattered to all."""
    import numpy as np

    mine = PETSc.Vec().createMPI((values.size, None), comm=PETSc.COMM_WORLD)
    mine.setArray(values)
    scatter, full = PETSc.Scatter.toAll(mine)
    try:
        scatter.scatter(mine, full, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return np.array(full.getArray(readonly=True))
    finally:
        for obj in (scatter, full, mine):
            obj.destroy()


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
    return _to_all(PETSc, values).reshape(PETSc.COMM_WORLD.size, values.size)


def broadcast(obj):
    """Rank 0's `obj` (picklable) on every rank (collective; the other ranks' `obj` is not read):
    its pickle's bytes, one per value of a vector that rank 0 alone holds, scattered to all
    (petsc4py has no broadcast of objects; mpi4py is not required)."""
    import numpy as np

    PETSc = _world()
    if PETSc is None:
        return obj
    first = PETSc.COMM_WORLD.rank == 0
    data = np.frombuffer(pickle.dumps(obj), np.uint8) if first else np.empty(0, np.uint8)
    return pickle.loads(_to_all(PETSc, data.astype(float)).astype(np.uint8).tobytes())


def reduce_max(value: float) -> float:
    """The largest of the ranks' `value`, on every rank (collective)."""
    return float(gathered([value]).max())


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


_NOTED = {"signal": 0, "delivering": False}


def _several() -> bool:
    """Whether this process is one of several ranks that agree (known once MPI is started: not
    started here, as from a signal handler)."""
    return "petsc4py.PETSc" in sys.modules and _world() is not None


def defer(signum: int) -> bool:
    """For a handler of SIGINT or SIGTERM: True where the signal is noted for the ranks' next agreed
    point (several ranks), False where the handler acts now (one process, or :func:`deliver`)."""
    if _NOTED["delivering"] or not _several():
        return False
    _NOTED["signal"] = max(_NOTED["signal"], int(signum))
    return True


def pending() -> int:
    """The signal noted on this rank since the last delivery (0: none)."""
    return _NOTED["signal"]


def deliver(signum: int) -> None:
    """Raise `signum` here, on every rank at the same point: to the handlers that
    :func:`noting_signals` replaced (the command line's, which then raise)."""
    _NOTED["signal"] = 0
    for sig, handler in _REPLACED.items():
        signal.signal(sig, handler)
    _REPLACED.clear()
    _NOTED["delivering"] = True
    try:
        signal.raise_signal(signum)
    finally:
        _NOTED["delivering"] = False


_REPLACED: dict = {}  # signal -> the handler noting_signals replaced


@contextlib.contextmanager
def noting_signals():
    """For the block, where there are several ranks (in the main thread): SIGINT and SIGTERM noted
    (:func:`defer`), the handlers that were there back after it (and at :func:`deliver`)."""
    if ranks() < 2 or threading.current_thread() is not threading.main_thread() or _REPLACED:
        yield
        return

    def note(signum, frame):
        defer(signum)

    for sig in SIGNALS:
        previous = signal.signal(sig, note)
        if previous is not None:  # None: not set from Python, nothing to restore
            _REPLACED[sig] = previous
    try:
        yield
    finally:
        for sig, handler in _REPLACED.items():
            signal.signal(sig, handler)
        _REPLACED.clear()


def at_agreed_point() -> None:
    """Where every rank passes alike (after a study's case): the largest signal any rank noted is
    raised on every rank (collective where there are several ranks)."""
    if _several():
        noted = int(gathered([pending()]).max())
        if noted:
            deliver(noted)
