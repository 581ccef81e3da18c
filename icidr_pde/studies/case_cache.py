"""A folder of finished cases, so that a sweep resumes where it stopped (``tstar --cache DIR``).

Each finished case is one JSON file ``<key>.json`` holding the case, its result and the key;
the key hashes everything that determines the result: the study's function, the case (law,
scene, scheme, N, tolerances, engine, ...: every keyword argument; the text of a law file), and the code version
(:func:`code_version`: this package's sources and the versions of Python and of the numerical
libraries under it). A rerun of the same sweep takes what is there and runs the rest; a
changed setting or a changed source is another key, so the old entry is not used. An entry is
written whole or not at all (:func:`icidr_pde.outputs.write_json`: a temporary file renamed
into place), so an interrupted sweep keeps every case that finished; an entry that cannot be
read, or whose stored case or key is not the one asked for, is run again and rewritten.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from pathlib import Path

from ..mpi_ranks import at_agreed_point
from ..outputs import write_json, writable_folder
from .parallel import StudyInterrupted, run_cases

__all__ = ["CaseCache", "code_version", "finished", "run_cached"]

#: the libraries whose round-off and step control a result depends on (their versions enter the key)
_LIBRARIES = ("numpy", "scipy", "numba", "scikit-sundae", "py-pde", "sympy")
_VERSION: list[str] = []


def finished(result):
    """`result`, a run of a study's case, where it finished (reached t_end, failed or was stopped
    by its own limit); KeyboardInterrupt where it was interrupted: the run path turns Ctrl-C and
    SIGTERM into a Result, but a case cut short is not the case's answer, so the study stops there
    and keeps it neither in its cache nor in its table."""
    if result.interrupted:
        raise KeyboardInterrupt
    return result


def code_version() -> str:
    """Hash of every Python, C and template source of this package, with the versions of Python
    and of :data:`_LIBRARIES`: a change to any of them makes every key new."""
    if not _VERSION:
        from importlib import metadata

        h = hashlib.sha256(sys.version.encode())
        for name in _LIBRARIES:
            try:
                h.update(f"\0{name}={metadata.version(name)}".encode())
            except metadata.PackageNotFoundError:
                h.update(f"\0{name}=none".encode())
        root = Path(__file__).resolve().parents[1]
        for path in sorted(p for p in root.rglob("*") if p.suffix in (".py", ".c", ".h", ".toml") and p.is_file()):
            h.update(b"\0" + str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
        _VERSION.append(h.hexdigest()[:16])
    return _VERSION[0]


def _canonical(function: str, case: dict) -> str:
    try:
        return json.dumps({"function": function, "case": case}, sort_keys=True, allow_nan=True)
    except TypeError as err:
        raise ValueError(f"`cache` keeps cases of JSON values (numbers, strings, lists) only; "
                         f"case {case!r} has another: {err}") from None


class CaseCache:
    """Finished cases of the study `function` (a name) in the folder `path` (made if missing;
    OutputError naming `option` if it cannot be written)."""

    def __init__(self, path, function: str, option: str = "cache"):
        self.folder = writable_folder(option, path)
        self.function = function

    def key(self, case: dict) -> str:
        from ..rheology.law_files import is_file_law

        text = _canonical(self.function, case)
        law = case.get("rheology")
        if is_file_law(law) and Path(law).is_file():  # a law read from a file: its text decides the result
            text += "\0" + hashlib.sha256(Path(law).read_bytes()).hexdigest()
        return hashlib.sha256(f"{text}\0{code_version()}".encode()).hexdigest()[:32]

    def _path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def get(self, case: dict):
        """The stored result of `case`, or None (not there, unreadable, or not this case's)."""
        key = self.key(case)
        try:
            with open(self._path(key), encoding="utf-8") as fh:
                entry = json.load(fh)
        except (OSError, ValueError):
            return None
        if not isinstance(entry, dict) or entry.get("key") != key or "result" not in entry \
                or json.dumps(entry.get("case"), sort_keys=True) != json.dumps(case, sort_keys=True):
            return None
        return entry["result"]

    def put(self, case: dict, result) -> None:
        """Store `result` (JSON values) of `case`, atomically."""
        key = self.key(case)
        write_json({"key": key, "function": self.function, "code_version": code_version(), "case": case,
                    "result": result}, self._path(key))

    def __len__(self) -> int:
        return sum(1 for name in os.listdir(self.folder) if name.endswith(".json") and not name.startswith("."))


def _indexed(function, item):
    index, case = item
    return index, function(case)


def run_cached(function, cases: list, cache, name: str, *, jobs: int, progress: bool, postfix=None,
               expect=None, **options) -> list:
    """``function(case)`` for every case (:func:`~.parallel.run_cases`), in the order of `cases`;
    interrupted, :class:`~.parallel.StudyInterrupted` with the results so far (None: not finished).

    With `cache` (a folder) the study `name`'s cases found there are not run, and every result is
    kept there (JSON values only) as it arrives, so an interrupted study resumes; a result taken
    from the cache is its JSON form (a tuple comes back as a list). `postfix(case, result)`
    labels the progress bar; `options` go to run_cases (``desc``, ``client``, ``init_here``).
    `expect`, (what, predicate): the shape every computed result must have; a result of another
    shape (a cluster's worker that does not run this package's function, see
    :func:`~.distributed.check_task_result`) is a ValueError, one line, before it is used.
    Under an MPI launcher every rank runs the same cases (the PETSc engine's runs are collective):
    a case is taken from the cache only where every rank found it, and rank 0 alone writes.
    """
    from .distributed import check_task_result

    store = None if cache is None else CaseCache(cache, name)
    kept = [None if store is None else store.get(case) for case in cases]
    if store is not None:  # under MPI a case is taken from the cache where every rank found it
        from ..mpi_ranks import everywhere

        kept = [k if found else None for k, found in zip(kept, everywhere([k is not None for k in kept]))]
    results = [None] * len(cases)
    todo = []
    for i, case in enumerate(cases):
        if kept[i] is None:
            todo.append((i, case))
        else:
            results[i] = kept[i]
    pending = {i for i, _ in todo}

    def checked(item):
        check_task_result(item, "an (index, result) pair of a case not yet done",
                          lambda x: isinstance(x, tuple) and len(x) == 2 and type(x[0]) is int
                          and x[0] in pending)
        if expect is not None:
            check_task_result(item[1], *expect)
        return item

    label = None if postfix is None else (lambda item: postfix(cases[checked(item)[0]], item[1]))
    try:
        for i, result in map(checked, run_cases(functools.partial(_indexed, function), todo, jobs, progress,
                                                ordered=False, postfix=label, **options)):
            pending.discard(i)
            if store is not None:
                store.put(cases[i], result)
            results[i] = result
            at_agreed_point()  # under MPI: a signal noted during the case, raised on every rank here
    except KeyboardInterrupt as interrupt:  # what finished goes with it (None: not run)
        raise StudyInterrupted(results) from interrupt
    return results
