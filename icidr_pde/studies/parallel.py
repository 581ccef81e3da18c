"""Worker processes for the studies: one BLAS thread each, spawned, with a progress bar.

:func:`run_cases` runs on a process pool of this machine, or, given a dask client, as its
tasks (:func:`map_cases`, with one progress bar over them; the client is :mod:`.distributed`'s:
a ``LocalCluster`` or a cluster's scheduler).
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import re
import signal
import sys
import warnings

from ..validation import integer

__all__ = ["StudyInterrupted", "blas_threads", "limit_blas_threads", "map_cases", "max_processes", "run_cases",
           "single_thread_environment", "worker_init", "worker_state"]


class StudyInterrupted(KeyboardInterrupt):
    """A study stopped by Ctrl-C (or SIGTERM) with what had finished: `done`, in the form of the
    function that raises it (a list with None for the cases not run, a sweep's partial mapping)."""

    def __init__(self, done):
        super().__init__("interrupted")
        self.done = done

_BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


#: (set, get) symbols of OpenBLAS's thread count in the builds numpy and scipy ship and in plain OpenBLAS
_THREAD_SYMBOLS = (("openblas_set_num_threads", "openblas_get_num_threads"),
                   ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
                   ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
                   ("openblas_set_num_threads64_", "openblas_get_num_threads64_"))


#: (set_threads, get_threads) of each OpenBLAS library path found, None where it has neither: a
#: library once loaded stays, and opening and asking it again at every case of a serial study cost more
#: than a small case's solve
_THREAD_FUNCTIONS: dict[str, tuple | None] = {}


def _openblas_libraries():
    """(name, set_threads, get_threads) of every OpenBLAS library loaded in this process."""
    try:
        with open("/proc/self/maps") as fh:
            # the lines naming openblas picked first: a regular expression over every line of a
            # process with hundreds of libraries mapped cost more than a small case's solve
            paths = sorted({path for line in fh.read().splitlines() if "openblas" in line
                            for path in re.findall(r"(/\S*openblas\S*\.so\S*)", line)})
    except OSError:
        return
    for path in paths:
        if path not in _THREAD_FUNCTIONS:
            _THREAD_FUNCTIONS[path] = _thread_functions(path)
        if _THREAD_FUNCTIONS[path] is not None:
            yield (os.path.basename(path), *_THREAD_FUNCTIONS[path])


def _thread_functions(path: str):
    try:
        lib = ctypes.CDLL(path)
    except OSError:
        return None
    for setter, getter in _THREAD_SYMBOLS:
        if hasattr(lib, setter) and hasattr(lib, getter):
            return getattr(lib, setter), getattr(lib, getter)
    return None


def blas_threads() -> dict[str, int]:
    """{library: its thread count} of the OpenBLAS libraries loaded in this process."""
    return {name: int(get()) for name, _, get in _openblas_libraries()}


def limit_blas_threads(n: int = 1) -> list[str]:
    """Limit the threads of the OpenBLAS libraries already loaded in this process.

    The dense LU of the Chebyshev Jacobian (3N x 3N) is many times slower with OpenBLAS's
    default threads than with one on a machine whose cores are busy: its threads wait for
    each other's cores (measured in docs/chebyshev.md). Returns the libraries that were
    limited (an empty list if none could be).
    """
    done = []
    for name, set_threads, _ in _openblas_libraries():
        set_threads(int(n))
        done.append(name)
    return done


#: worker processes a pool or LocalCluster of this machine may start, per core it may use: more
#: only share the cores (each worker is one thread) and each holds its own Python and numpy
PROCESSES_PER_CORE = 4


def max_processes() -> int:
    """The most worker processes of this machine (``jobs``, ``workers``): :data:`PROCESSES_PER_CORE`
    per core this process may use. A bound checked before any process is started: a count in the
    thousands would start them all (until the process limit refuses, with a traceback)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return PROCESSES_PER_CORE * max(1, cores)


def single_thread_environment() -> None:
    """One BLAS thread in the worker processes spawned from now on (read before numpy loads)."""
    for var in _BLAS_ENV:
        os.environ.setdefault(var, "1")


def worker_init() -> None:
    """The state of a worker process, for good: one BLAS thread, warnings off."""
    limit_blas_threads(1)
    warnings.simplefilter("ignore")


def _pool_worker_init() -> None:
    """A worker of :func:`run_cases`'s pool: :func:`worker_init`, and Ctrl-C left to the parent
    (a terminal sends it to every process of the group: each worker printed a traceback), which
    stops the pool."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    worker_init()


@contextlib.contextmanager
def worker_state():
    """A worker's state (:func:`worker_init`) for the block only: the caller's BLAS thread
    counts and warning filters are restored after it, whatever happens in it."""
    before = [(set_threads, int(get())) for _, set_threads, get in _openblas_libraries()]
    with warnings.catch_warnings():
        worker_init()
        try:
            yield
        finally:
            for set_threads, n in before:
                set_threads(n)


def _in_worker_state(function):
    """`function` run in :func:`worker_state` at every call (the serial path of :func:`run_cases`)."""
    def call(case):
        with worker_state():
            return function(case)

    return call


_initialised = False


def _task(function, case):
    """`function(case)` in a worker: one BLAS thread, warnings off, as the process pool does."""
    global _initialised
    if not _initialised:
        worker_init()
        _initialised = True
    return function(case)


def map_cases(function, cases: list, client, progress: bool, *, ordered: bool = True, desc=None,
              postfix=None):
    """Yield function(case) for every case, computed as tasks of `client`.

    With ``ordered=False`` results come as they finish; `postfix(result)` labels the bar.
    An exception of a task is raised here (with the worker's traceback); the tasks not yet
    run are cancelled when the caller stops (or is interrupted).
    """
    from distributed import as_completed
    from tqdm.auto import tqdm

    futures = [client.submit(_task, function, case, pure=False) for case in cases]
    index = {f.key: i for i, f in enumerate(futures)}
    done: dict[int, object] = {}
    following = 0
    try:
        with tqdm(total=len(cases), desc=desc, disable=not progress, file=sys.stderr) as bar:
            for future in as_completed(futures):
                result = future.result()
                if postfix is not None:
                    bar.set_postfix_str(postfix(result))
                bar.update()
                if not ordered:
                    yield result
                    continue
                done[index[future.key]] = result
                while following in done:
                    yield done.pop(following)
                    following += 1
    finally:
        client.cancel([f for f in futures if not f.done()])


def run_cases(function, cases: list, jobs: int, progress: bool, *, ordered: bool = True, desc=None,
              postfix=None, client=None, init_here: bool = True):
    """Yield function(case) for every case, in `jobs` spawned workers (jobs=1: this process),
    or as tasks of the dask `client` if given (`jobs` is then unused).

    With ``ordered=False`` results come as they finish; `postfix(result)` labels the bar.
    With jobs=1 and `init_here`, each call runs in a worker's state (one BLAS thread, warnings
    off: the numbers of a worker) and the caller's state is restored after it
    (:func:`worker_state`); ``init_here=False`` runs the calls in the caller's state (a
    study's serial default).
    """
    if client is not None:
        yield from map_cases(function, cases, client, progress, ordered=ordered, desc=desc, postfix=postfix)
        return
    jobs = integer("jobs", jobs, 1, max_processes())
    from tqdm.auto import tqdm

    with tqdm(total=len(cases), desc=desc, disable=not progress, file=sys.stderr) as bar:
        if jobs == 1:
            results = map(_in_worker_state(function) if init_here else function, cases)
            pool = None
        else:
            single_thread_environment()
            pool = multiprocessing.get_context("spawn").Pool(jobs, initializer=_pool_worker_init)
            results = (pool.imap if ordered else pool.imap_unordered)(function, cases)
        finished = False
        try:
            for result in results:
                if postfix is not None:
                    bar.set_postfix_str(postfix(result))
                bar.update()
                yield result
            finished = True
        finally:
            if pool is not None:
                if finished:
                    pool.close()
                else:  # interrupted, an error, or the caller stopped: the queued cases are not run
                    pool.terminate()
                pool.join()
