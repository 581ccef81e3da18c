"""What every subcommand of ``icidr-pde`` shares: the exit statuses, the parser class (one error
prefix, defaults in --help), the signals that stop a run and keep its results, and the writing
of outputs with one line per failure."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

from ..mpi_ranks import defer, launcher_rank

EXIT_OK, EXIT_BAD_INPUT, EXIT_RUN_FAILED, EXIT_WRITE_FAILED = 0, 2, 3, 4
EXIT_INTERRUPTED = {signal.SIGINT: 130, signal.SIGTERM: 143}
PREFIX = "icidr-pde: error:"



def check_engine(engine) -> None:
    """Refuse, before any work, an engine this process cannot start: the PETSc engine without
    petsc4py (the message names the extra), beside another MPI or under another MPI's launcher
    (ValueError: one line, exit 2). Starts PETSc (MPI) on every rank of an MPI run."""
    if engine == "petsc":
        from ..engines.petsc import rank

        try:
            rank()
        except ImportError as err:
            raise ValueError(str(err)) from None


class Parser(argparse.ArgumentParser):
    """argparse with one error prefix for every subcommand and defaults shown in --help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", DefaultsFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        if launcher_rank() != 0:  # before MPI starts: the launcher's rank 0 alone says it
            self.exit(EXIT_BAD_INPUT)
        self.print_usage(sys.stderr)
        self.exit(EXIT_BAD_INPUT, f"{PREFIX} {message}\n")


class DefaultsFormatter(argparse.RawDescriptionHelpFormatter):
    """Append '(default: ...)' to every option help that has a meaningful default."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if "default" in text or default in (None, False, argparse.SUPPRESS) or not action.option_strings:
            return text
        shown = " ".join(map(str, default)) if isinstance(default, (list, tuple)) else default
        return f"{text} (default: {shown})".strip()



def check_output_path(option: str, path) -> None:
    """Refuse, before any work, an output path that cannot be written."""
    from ..outputs import check_outputs

    check_outputs({option: path})


def figure_path(option: str, path):
    """The file a figure is written to: a supported suffix, '.png' appended if none."""
    if path is None:
        return None
    if not os.fspath(path):  # the empty path is no directory: check_outputs names what it is
        check_output_path(option, path)
    from matplotlib.figure import Figure

    if Path(path).is_dir():
        raise ValueError(f"`{option}` {str(path)!r} is a directory")
    supported = Figure().canvas.get_supported_filetypes()
    suffix = Path(path).suffix.lstrip(".").lower()
    if not suffix:
        path = f"{path}.png"
    elif suffix not in supported:
        raise ValueError(f"`{option}` must end in one of {sorted('.' + s for s in supported)}; got {path!r}")
    check_output_path(option, path)
    return str(path)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the run stops cleanly and keeps its results."""


class interrupt_signals:
    """Context: SIGTERM stops the run like SIGINT; `received` is the signal that came (of several MPI
    ranks, each raises it at the same point: :mod:`icidr_pde.mpi_ranks`)."""

    def __enter__(self):
        self.received = None
        self._previous = {}
        for sig in EXIT_INTERRUPTED:
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread
                pass
        return self

    def _handle(self, signum, frame):
        self.received = signal.Signals(signum)
        if defer(signum):  # one of several MPI ranks: raised on every rank at the next agreed point
            return
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        return False


def is_stdout(path) -> bool:
    """Whether `path` is this process's standard output (``/dev/stdout``, ``/proc/self/fd/1``, the file
    or pipe stdout goes to)."""
    if path is None:
        return False
    try:
        here, there = os.stat(path), os.fstat(sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def write_outputs(writers, report=None) -> int:
    """Call each (option, path, write) in turn; report failures; EXIT_WRITE_FAILED if any. What was
    written is said on `report` (default stdout)."""
    status = EXIT_OK
    for option, path, write in writers:
        if path is None:
            continue
        try:
            write(path)
        except (OSError, ValueError) as err:
            print(f"{PREFIX} could not write {option} {path}: {getattr(err, 'strerror', None) or err}",
                  file=sys.stderr)
            status = EXIT_WRITE_FAILED
        except KeyboardInterrupt:  # the outputs written so far stay; this one is left as it was
            print(f"{PREFIX} interrupted while writing {option} {path}; it was not written", file=sys.stderr)
            raise
        else:
            print(f"{option.lstrip('-')} written to {path}", file=report or sys.stdout)
    return status
