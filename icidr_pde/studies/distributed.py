"""Independent runs as dask.distributed tasks: on this machine or on a cluster.

* :func:`cluster` -- a :class:`distributed.Client` on a ``LocalCluster`` of `workers`
  processes (one thread, one BLAS thread each), or on the scheduler at `scheduler`
  (a cluster started by ``dask scheduler``/``dask worker`` or by dask-jobqueue);
* :func:`run_many` -- :func:`icidr_pde.api.run` for a list of cases, the
  :class:`~icidr_pde.result.Result`\\ s in the order asked; a task that raised is a
  :class:`TaskError` naming its case, in its place;
* :func:`check_task_result` -- a task's result of another shape refused in one line.

The options ``--workers N`` / ``--scheduler ADDRESS`` of the commands that run independent
runs open their client through :func:`cluster` (:mod:`icidr_pde.cli.cluster`).

A task computes what the serial run computes: the same function on the same arguments in
a process with one BLAS thread, so t* agrees bit for bit (tests/test_distributed.py).
dask is the optional extra ``pip install "icidr-pde[dask]"``; see docs/distributed.md.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import socket
import sys
import traceback
from dataclasses import dataclass

from ..validation import integer
from .parallel import map_cases, max_processes, run_cases, single_thread_environment

__all__ = ["TaskError", "check_task_result", "cluster", "run_many"]

#: seconds to wait for a scheduler to answer before giving up (bad input, exit 2 on the CLI)
CONNECT_TIMEOUT = 3.0
#: seconds the client may take to start on a scheduler that answered (a loaded machine is slow)
CLIENT_TIMEOUT = 60.0


@dataclass
class TaskError:
    """A case whose task raised: the case (keyword arguments), the exception's type and
    message, and the worker's traceback."""

    case: dict
    error: str
    traceback: str

    def __str__(self) -> str:
        return f"case {self.case!r} raised {self.error}"


def _distributed():
    try:
        import distributed
    except ImportError:
        raise ValueError("`workers`/`scheduler` need dask.distributed, which is not installed: "
                         "pip install 'icidr-pde[dask]'") from None
    return distributed


@contextlib.contextmanager
def cluster(workers: int | None = None, scheduler: str | None = None, *, dashboard: bool = False):
    """A dask Client for the block: on `scheduler` (an address such as tcp://host:8786, or the
    file that ``dask scheduler --scheduler-file`` writes) if given, else on a new ``LocalCluster`` of `workers` processes, closed at the end.

    A scheduler that does not answer within :data:`CONNECT_TIMEOUT` seconds is bad input
    (ValueError naming it). With `dashboard`, the dashboard's link is printed on stderr.
    """
    if scheduler is not None and workers is not None:
        raise ValueError(f"give `workers` (a cluster on this machine) or `scheduler` (an existing one), "
                         f"not both; got workers={workers!r}, scheduler={scheduler!r}")
    if scheduler is None:
        workers = integer("workers", workers, 1, max_processes())
    distributed = _distributed()
    with contextlib.ExitStack() as stack:
        if scheduler is None:
            single_thread_environment()  # inherited by the spawned worker processes
            local = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                             host="127.0.0.1", dashboard_address="127.0.0.1:0",
                                             silence_logs=logging.ERROR)
            stack.enter_context(local)
            client = stack.enter_context(distributed.Client(local))
        else:
            client = stack.enter_context(_connect(distributed, scheduler))
        if dashboard:
            print(f"dask dashboard: {client.dashboard_link}", file=sys.stderr, flush=True)
        yield client


def _connect(distributed, address: str):
    """A Client on the scheduler at `address` (or named by the scheduler file `address`, which
    must be trusted: :func:`_scheduler_address`). The scheduler is probed first, its port and then
    its answer as a dask scheduler: a Client that fails to start can hang in its own clean-up
    (distributed's LoopRunner.stop, seen under load), and one on a port that accepts but never
    speaks waits without end in distributed's handshake, so it is made only once the scheduler
    has answered."""
    target = _scheduler_address(address)
    try:
        _probe(target)
        _ask_identity(target)
        return distributed.Client(address=target, timeout=CLIENT_TIMEOUT)
    except Exception as err:  # OSError, TimeoutError, ValueError of a malformed address, ...
        reason = (str(err).strip().splitlines() or [type(err).__name__])[0]
        raise ValueError(f"`scheduler` must be the address of a running dask scheduler "
                         f"(tcp://host:port) or its scheduler file; could not connect to {address!r}: "
                         f"{reason}") from None


def _scheduler_address(address: str) -> str:
    """The address itself, or the one the scheduler file `address` holds. The file names the
    cluster this process will trust with its account (docs/security.md), so it is read only if
    this user owns it and nobody else can write it: the kernel cache's check
    (:func:`icidr_pde.kernel_cache.untrusted`), a ValueError naming the option otherwise."""
    if not os.path.isfile(address):
        return address
    from ..kernel_cache import untrusted

    try:
        with open(address, "rb") as f:
            reason = untrusted(os.fstat(f.fileno()))  # the file read, not the name: no race
            text = None if reason else f.read(1 << 20)
    except OSError as err:
        raise ValueError(f"`scheduler` file {address!r} cannot be read: {err.strerror or err}") from None
    if reason:
        raise ValueError(f"`scheduler` file {address!r} is {reason}: it names the cluster this process "
                         f"trusts with your account, so it is not used")
    try:
        target = json.loads(text)["address"]
    except (ValueError, KeyError, TypeError) as err:
        raise ValueError(f"`scheduler` file {address!r} must be the JSON a dask scheduler writes "
                         f"(--scheduler-file), with its address; {type(err).__name__}: {err}") from None
    if not isinstance(target, str):
        raise ValueError(f"`scheduler` file {address!r}: its address must be a string; got {target!r}")
    return target


def _probe(address: str) -> None:
    """Raise unless a TCP connection to tcp://host:port opens within CONNECT_TIMEOUT seconds."""
    scheme, sep, rest = address.rpartition("://")
    if not sep or scheme != "tcp":
        raise ValueError(f"not a tcp://host:port address: {address!r}")
    host, _, port = rest.rpartition(":")
    with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
        pass


def _ask_identity(address: str) -> None:
    """Raise unless a dask scheduler at `address` completes distributed's handshake and says
    who it is within CONNECT_TIMEOUT seconds (distributed's own connect waits for the handshake
    without a time limit)."""
    import asyncio
    import concurrent.futures

    from distributed.comm import connect

    async def ask():
        comm = await connect(address, timeout=CONNECT_TIMEOUT)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    async def within_timeout():
        try:
            return await asyncio.wait_for(ask(), CONNECT_TIMEOUT)
        except asyncio.TimeoutError:
            raise TimeoutError(f"no answer as a dask scheduler within {CONNECT_TIMEOUT:g} s") from None

    # its own event loop in its own thread: the caller may be running one (a notebook)
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        reply = pool.submit(asyncio.run, within_timeout()).result()
    if not isinstance(reply, dict) or reply.get("type") != "Scheduler":
        kind = reply.get("type") if isinstance(reply, dict) else type(reply).__name__
        raise ValueError(f"it answered, but as {kind!r}, not as a dask scheduler")


def check_task_result(value, what: str, predicate) -> None:
    """A ValueError, one line, unless the result `value` of a task is `what` (``predicate(value)``).
    A cluster's workers run what their own installation and start-up (``--preload``) make them
    run, and a result comes back unpickled: one of another shape is refused before it is used, not
    read as a t*. (That unpickling can itself run code in this process: docs/security.md.)"""
    if not predicate(value):
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise ValueError(f"a task returned {shown} (of type {type(value).__name__}), not {what}: the cluster's "
                         f"workers do not run this package's functions (`scheduler` names a cluster this "
                         f"process trusts with your account)")


def _run_one(case: dict):
    """api.run(**case); an exception is returned as a :class:`TaskError` (a blow-up is a Result)."""
    from ..api import run

    try:
        return run(**case)
    except Exception as err:
        return TaskError(dict(case), f"{type(err).__name__}: {err}", traceback.format_exc())


def run_many(cases, client=None, workers: int | None = None, *, progress: bool = False) -> list:
    """:func:`icidr_pde.api.run` for every case (a dict of its keyword arguments), as dask tasks.

    On `client` if given, else on a ``LocalCluster`` of `workers` processes started for the
    call, else (neither) one after the other in this process. Returns, in the order of
    `cases`, a :class:`~icidr_pde.result.Result` per case (a run that blew up is one, with
    ``blew_up`` and ``t_star``) or a :class:`TaskError` for a case whose run raised (bad
    input, say): one failure does not stop the others.
    """
    cases = [dict(c) for c in cases]
    for i, case in enumerate(cases):
        for name in ("progress", "live_plot", "on_result"):
            if case.get(name):
                raise ValueError(f"`cases[{i}]` asks for {name}={case[name]!r}, which a task cannot show "
                                 f"or call back; use progress=True of run_many for one bar over the runs")
    if client is not None and workers is not None:
        raise ValueError(f"give `client` or `workers`, not both; got workers={workers!r}")
    if client is not None:
        return list(map_cases(_run_one, cases, client, progress, desc="runs"))
    if workers is not None:
        with cluster(workers) as own:
            return list(map_cases(_run_one, cases, own, progress, desc="runs"))
    return list(run_cases(_run_one, cases, 1, progress, desc="runs"))
