"""Worker processes for the studies: one BLAS thread each, spawned, with a progress bar.

:func:`run_cases` runs on a process pool of this machine, or, given a dask client, as its
tasks (:mod:`.distributed`: a ``LocalCluster`` or a cluster's scheduler).
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import re
import sys
import warnings

__all__ = ["limit_blas_threads", "run_cases", "single_thread_environment", "worker_init"]

_BLAS_ENV = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads(n: int = 1) -> list[str]:
    """Limit the threads of the OpenBLAS libraries already loaded in this process.

    The dense LU of the Chebyshev Jacobian (3N x 3N) is ~25 times slower with OpenBLAS's
    default threads on a busy 2-core machine than with one thread. Returns the libraries
    that were limited (an empty list if none could be).
    """
    done = []
    try:
        with open("/proc/self/maps") as fh:
            libs = sorted(set(re.findall(r"(/\S*openblas\S*\.so\S*)", fh.read())))
    except OSError:
        return done
    for path in libs:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in ("openblas_set_num_threads", "scipy_openblas_set_num_threads64_",
                       "scipy_openblas_set_num_threads", "openblas_set_num_threads64_"):
            if hasattr(lib, symbol):
                getattr(lib, symbol)(int(n))
                done.append(os.path.basename(path))
                break
    return done


def single_thread_environment() -> None:
    """One BLAS thread in the worker processes spawned from now on (read before numpy loads)."""
    for var in _BLAS_ENV:
        os.environ.setdefault(var, "1")


def worker_init() -> None:
    limit_blas_threads(1)
    warnings.simplefilter("ignore")


def run_cases(function, cases: list, jobs: int, progress: bool, *, ordered: bool = True, desc=None,
              postfix=None, client=None, init_here: bool = True):
    """Yield function(case) for every case, in `jobs` spawned workers (jobs=1: this process),
    or as tasks of the dask `client` if given (`jobs` is then unused).

    With ``ordered=False`` results come as they finish; `postfix(result)` labels the bar.
    With jobs=1, `init_here` gives this process the workers' set-up (one BLAS thread,
    warnings off) for good; ``init_here=False`` leaves it as it is (a study's serial default).
    """
    if client is not None:
        from .distributed import map_cases

        yield from map_cases(function, cases, client, progress, ordered=ordered, desc=desc, postfix=postfix)
        return
    from tqdm.auto import tqdm

    with tqdm(total=len(cases), desc=desc, disable=not progress, file=sys.stderr) as bar:
        if jobs <= 1:
            if init_here:
                worker_init()
            results = map(function, cases)
            pool = None
        else:
            single_thread_environment()
            pool = multiprocessing.get_context("spawn").Pool(jobs, initializer=worker_init)
            results = (pool.imap if ordered else pool.imap_unordered)(function, cases)
        try:
            for result in results:
                if postfix is not None:
                    bar.set_postfix_str(postfix(result))
                bar.update()
                yield result
        finally:
            if pool is not None:
                pool.close()
                pool.join()
