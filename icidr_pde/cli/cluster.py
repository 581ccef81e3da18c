"""The options of every command that runs independent runs (``icidr-pde tstar``, ``dem`` and
``study``): ``--jobs N`` (this machine's process pool), ``--workers N`` or ``--scheduler ADDRESS``
(dask, :func:`icidr_pde.studies.distributed.cluster`) and ``--cache DIR`` (the finished runs,
:func:`icidr_pde.studies.case_cache.run_cached`), parsed and checked in this one place.
"""

from __future__ import annotations

import argparse
import contextlib

from .argtypes import int_at_least
from ..outputs import writable_folder
from ..studies.distributed import cluster
from ..studies.parallel import max_processes

__all__ = ["add_cluster_options", "client_of", "add_cache_option", "check_cache_option"]


_count_argument = int_at_least(1, max_processes())  # argparse type of --workers and --jobs


def add_cluster_options(parser: argparse.ArgumentParser, what: str = "the runs", *, jobs: int = 1) -> None:
    """Add ``--jobs N`` (this machine's process pool; default `jobs`, 1: one run after the
    other in this process) and ``--workers N`` or ``--scheduler ADDRESS`` (dask; one or the
    other) to `parser`; :func:`client_of` opens the client they ask for."""
    parser.add_argument("--jobs", type=_count_argument, default=jobs, metavar="N",
                        help=f"worker processes of this machine's process pool for {what} (default {jobs})")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=_count_argument, default=None, metavar="N",
                       help=f"run {what} as dask tasks on a LocalCluster of N processes (needs the [dask] extra)")
    group.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help=f"run {what} as tasks of the dask cluster whose scheduler is at ADDRESS "
                            "(e.g. tcp://10.0.0.1:8786, or a file of `dask scheduler --scheduler-file`)")


@contextlib.contextmanager
def client_of(args, *, dashboard: bool = True):
    """The dask client of ``args.workers``/``args.scheduler`` for the block (None without
    either: the caller's own serial path or process pool), its dashboard's link printed.

    A cluster that cannot start or a scheduler that does not answer is bad input: a ValueError
    naming the option (``icidr-pde`` prints it as one line, exit 2).

    Under an MPI launcher (``mpiexec -n P``, ``srun``) the ranks compute each run together (the
    PETSc engine), one run after the other in this process: ``args.jobs`` is set to 1, and
    ``--workers`` or ``--scheduler`` is bad input.
    """
    from ..mpi_ranks import launched

    if launched() > 1:
        given = "--workers" if args.workers is not None else "--scheduler" if args.scheduler is not None else None
        if given:
            raise ValueError(f"`{given}` must not be given under an MPI launcher ({launched()} processes): the "
                             "ranks compute each run together, one run after the other; got "
                             f"{given} {getattr(args, given[2:])}")
        args.jobs = 1
    if args.workers is None and args.scheduler is None:
        yield None
        return
    with contextlib.ExitStack() as stack:
        try:
            client = stack.enter_context(cluster(args.workers, args.scheduler, dashboard=dashboard))
        except ValueError as err:
            message = str(err)
            for name in ("workers", "scheduler"):
                message = message.replace(f"`{name}`", f"`--{name}`")
            raise ValueError(message) from None
        yield client


def add_cache_option(parser, what: str = "case") -> None:
    """``--cache DIR`` of a command whose runs are independent (``tstar``, ``study``)."""
    parser.add_argument("--cache", default=None, metavar="DIR",
                        help=f"keep each finished {what} in DIR and take it from there on a rerun (resumes an "
                             f"interrupted study; a {what} whose settings or code changed is run again)")


def check_cache_option(args) -> None:
    """Refuse a ``--cache`` that cannot be written, before any run (OutputError naming the option)."""
    if args.cache is not None:
        writable_folder("--cache", args.cache)
