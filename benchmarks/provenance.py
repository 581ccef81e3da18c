"""What a benchmark's JSON says about the run that measured it: command, date, machine, load, commit.

A number measured on a shared machine means little without the load it ran under, and a table
without its command cannot be measured again. Every benchmark writes its JSON through
:func:`write_json` (or, for a file of one line per case, :func:`append_jsonl`), which adds
:func:`record` under the key ``"provenance"``:

- ``command``: the command line that reproduces the run, ``python benchmarks/NAME.py ARGS``,
  preceded by ``nice -n K`` when the process ran at niceness K and by the thread-count variables
  of the environment it started with (``OPENBLAS_NUM_THREADS=1``);
- ``argv``: the arguments as the process received them;
- ``date`` and ``finished``: UTC ISO date-times of the start (the import of this module, at the
  top of the benchmark) and of the record;
- ``load``: the load averages over 1, 5 and 15 minutes at ``start`` and ``end``;
- ``cores``, ``memory_gib``, ``python``, ``platform``: the machine;
- ``commit``: HEAD of the checkout the benchmark lives in, ``"unknown"`` outside a checkout, and
  ``modified``: whether tracked files differed from it (None when unknown).

Files are written whole or not at all (icidr_pde.outputs): the JSON text is made before the file
is touched, so a value JSON cannot hold leaves the previous file as it was. docs/benchmark_pages.py
heads each measurement page with this record.
"""

from __future__ import annotations

import functools
import importlib.util
import json
import os
import platform
import shlex
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KEY = "provenance"
# environment variables that change a timing and that a command line sets in front of python
THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")

# the benchmark's start: it imports this module at its top, before it measures anything (and
# before it sets thread counts of its own, which are not part of the command typed)
_START_DATE = datetime.now(timezone.utc)
_START_LOAD = os.getloadavg()
_START_ENV = {name: os.environ[name] for name in THREADS if name in os.environ}
_START_DIR = os.getcwd()  # where argv[0] was typed from


@functools.cache
def _write_atomically():
    """icidr_pde.outputs.write_atomically of this checkout, loaded from its file: a benchmark may run
    another checkout's package (``--code``, ``--against``, PYTHONPATH), which need not have it; the
    module imports the standard library only."""
    spec = importlib.util.spec_from_file_location("benchmark_outputs", ROOT / "icidr_pde" / "outputs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.write_atomically


def _utc(moment: datetime) -> str:
    return moment.isoformat(timespec="seconds")


def command(argv) -> str:
    """The command line that runs `argv` again from the checkout's root (shell-quoted)."""
    script = argv[0] if argv else ""
    if script and Path(_START_DIR, script).is_file():
        path = Path(_START_DIR, script).resolve()
        script = str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)
    words = [f"{name}={value}" for name, value in _START_ENV.items()]
    niceness = os.nice(0)
    if niceness:
        words += ["nice", "-n", str(niceness)]
    return shlex.join(words + ["python", script, *argv[1:]])


def _git(*args: str) -> str | None:
    try:
        proc = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return proc.stdout.strip() if proc.returncode == 0 else None


def _memory_gib() -> float | None:
    try:
        return round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 2)
    except (ValueError, OSError, AttributeError):
        return None


def record(argv=None) -> dict:
    """The provenance of this run (see the module's docstring); `argv` defaults to ``sys.argv``."""
    argv = list(sys.argv if argv is None else argv)
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {"command": command(argv), "argv": argv,
            "date": _utc(_START_DATE), "finished": _utc(datetime.now(timezone.utc)),
            "load": {"start": list(_START_LOAD), "end": list(os.getloadavg())},
            "cores": os.cpu_count(), "memory_gib": _memory_gib(),
            "python": platform.python_version(), "platform": platform.platform(),
            "commit": commit or "unknown", "modified": None if status is None else bool(status)}


def write_json(path, data: dict, *, stamp: bool = True, argv=None, indent: int | None = 1, default=None) -> None:
    """Write `data` to `path` as JSON with :func:`record` under :data:`KEY`, whole or not at all.

    ``stamp=False`` writes `data` alone: a file a benchmark's own child process hands its parent,
    not a measurement (the child's time would include the record's)."""
    if stamp:
        data = {KEY: record(argv), **data}
    text = json.dumps(data, indent=indent, default=default)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    _write_atomically()(path, lambda fh: fh.write(text))


def append_jsonl(path, row: dict, *, argv=None, default=None) -> None:
    """Add `row`, with :func:`record` under :data:`KEY`, as one line of the JSON-lines file `path`;
    the file is rewritten whole, so that an interrupt never leaves half a line."""
    line = json.dumps({**row, KEY: record(argv)}, default=default) + "\n"
    path = Path(path)
    old = path.read_text() if path.exists() else ""
    if old and not old.endswith("\n"):
        old += "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_atomically()(path, lambda fh: fh.write(old + line))


if __name__ == "__main__":  # what a benchmark started with these arguments records
    print(json.dumps(record(), indent=1))
