"""Output files: written whole or not at all, with the mode a plain ``open(path, "w")`` gives.

Every file a user asks for (``--json``, ``--plot``, ``--save``, ``--movie``, figures, DEM
summaries, the stability reports) is written through :func:`replacing` or
:func:`write_atomically`:

- the data go to a temporary file made by :func:`tempfile.mkstemp` in the target's folder
  (an unpredictable name, created with ``O_EXCL``), which is renamed over the target only
  once complete; any error or interrupt removes it and leaves the target as it was;
- the file gets the mode of the file it replaces, or ``0o666`` less the umask for a new
  one (``mkstemp``'s own ``0o600`` never survives);
- a symbolic link is followed: its target is replaced, the link stays a link;
- a character device or a FIFO (``/dev/stdout``, ``/dev/null``, a pipe) is written through,
  never replaced;
- a directory is refused;
- under an MPI launcher, rank 0 alone installs files (:func:`icidr_pde.mpi_ranks.writes_here`):
  another rank's data go to a temporary file that is removed, so that every rank runs the same
  code and one file results.

:func:`check_outputs` refuses, before any work, an output that cannot be written and two
outputs onto one file. The rules are stated for users in docs/security.md ("Output files").
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import sys
import tempfile
from pathlib import Path

__all__ = ["write_atomically", "write_json", "replacing", "save_figure", "temporary_beside", "install", "discard",
           "check_outputs", "writable_folder", "new_file_mode", "OutputError", "OutputWriteError"]


class OutputError(ValueError):
    """An output path that cannot be written (raised before any work)."""


class OutputWriteError(OSError):
    """An output that could not be written (a full disk, a folder made read-only); the
    target is as it was. The command line exits 4."""


def _umask() -> int:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except OSError:
        pass
    mask = os.umask(0o22)  # no other portable way to read it
    os.umask(mask)
    return mask


def new_file_mode() -> int:
    """The mode ``open(path, "w")`` gives a new file: 0o666 less the umask."""
    return 0o666 & ~_umask()


def _real(path) -> Path:
    """`path` with every symbolic link resolved (the file a write through the link reaches);
    a device, FIFO or name under /dev or /proc as given (``/dev/stdout`` may lead to a pipe)."""
    if _is_stream(path):
        return Path(os.path.abspath(os.fspath(path)))
    return Path(os.path.realpath(os.fspath(path)))


def _is_stream(path) -> bool:
    """A character device, FIFO or socket, or a name under /dev or /proc (``/dev/stdout``
    redirected to a file leads to that file through /proc): written through, never replaced."""
    if os.path.abspath(os.fspath(path)).startswith(("/dev/", "/proc/")):
        return True
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return stat.S_ISCHR(mode) or stat.S_ISFIFO(mode) or stat.S_ISSOCK(mode)


def temporary_beside(path, suffix: str | None = None) -> Path:
    """A new empty file for the data of `path`: in the folder of the file `path` leads to
    (through symbolic links), or in the system's temporary folder when `path` is a device
    or a FIFO. It ends in `suffix` (default: the target's), so that writers choosing a format
    by suffix (matplotlib, ffmpeg, numpy) see the right one."""
    real = _real(path)
    if real.is_dir():
        raise IsADirectoryError(21, "Is a directory", str(path))
    suffix = real.suffix if suffix is None else suffix
    folder = None if _is_stream(real) else real.parent
    fd, tmp = tempfile.mkstemp(prefix=f".{real.stem}.", suffix=f".partial{suffix}", dir=folder)
    os.close(fd)
    return Path(tmp)


def install(tmp, path, *, fsync: bool = False) -> None:
    """Move the complete file `tmp` to `path` (see the module's rules); `tmp` is gone after."""
    tmp, real = Path(tmp), _real(path)
    try:
        if _is_stream(real):
            _write_through(tmp, real)
            return
        _copy_mode(real, tmp)
        if fsync:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        os.replace(tmp, real)
    finally:
        discard(tmp)


def _open_descriptor(path: Path) -> int | None:
    """The descriptor of this process that /dev/stdout, /dev/stderr, /dev/fd/N or /proc/self/fd/N name."""
    name = str(path)
    if name in ("/dev/stdin", "/dev/stdout", "/dev/stderr"):
        return ("/dev/stdin", "/dev/stdout", "/dev/stderr").index(name)
    for prefix in ("/dev/fd/", "/proc/self/fd/", f"/proc/{os.getpid()}/fd/"):
        if name.startswith(prefix) and name[len(prefix):].isdigit():
            return int(name[len(prefix):])
    return None


def _write_through(tmp: Path, real: Path) -> None:
    """Copy `tmp` to a device or FIFO; to this process's own stdout or stderr through its open
    descriptor, after what Python has buffered (a new open of /dev/stdout redirected to a file
    would write at its own offset, under the lines printed later)."""
    fd = _open_descriptor(real)
    with open(tmp, "rb") as src:
        if fd is None:
            with open(real, "ab") as dst:  # "ab": a device or FIFO has no size to truncate
                shutil.copyfileobj(src, dst)
            return
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(AttributeError, ValueError, OSError):
                stream.flush()
        while chunk := src.read(1 << 16):
            view = memoryview(chunk)
            while view:
                view = view[os.write(fd, view):]


def _copy_mode(real: Path, tmp: Path) -> None:
    """Give `tmp` the mode (and, where allowed, the owner) of the file it replaces, else the
    mode of a new file under the umask."""
    try:
        old = os.stat(real)
    except FileNotFoundError:
        os.chmod(tmp, new_file_mode())
        return
    os.chmod(tmp, stat.S_IMODE(old.st_mode) & 0o777)
    if (old.st_uid, old.st_gid) != (os.getuid(), os.getgid()):
        with contextlib.suppress(OSError):  # only root may give a file away
            os.chown(tmp, old.st_uid, old.st_gid)


def discard(tmp) -> None:
    """Remove a temporary file if it is still there."""
    with contextlib.suppress(FileNotFoundError):
        os.unlink(tmp)


@contextlib.contextmanager
def replacing(path, suffix: str | None = None, *, fsync: bool = False):
    """Context yielding a temporary path to write `path`'s data to; on a clean exit the file
    is installed at `path` (:func:`install`), on any exception (KeyboardInterrupt included)
    it is removed and `path` is left as it was."""
    if not _writes_here():
        yield from _elsewhere(path, suffix)
        return
    try:
        tmp = temporary_beside(path, suffix)
    except OSError as err:
        raise _write_error(path, err) from err
    try:
        yield tmp
    except OSError as err:
        discard(tmp)
        raise _write_error(path, err) from err
    except BaseException:
        discard(tmp)
        raise
    try:
        install(tmp, path, fsync=fsync)
    except OSError as err:
        raise _write_error(path, err) from err


def _writes_here() -> bool:
    """Whether this process installs files (:mod:`icidr_pde.mpi_ranks`; True where this module is
    loaded alone, from its file, by benchmarks/provenance.py)."""
    if not __package__:
        return True
    from .mpi_ranks import writes_here

    return writes_here()


def _elsewhere(path, suffix):
    """A rank other than 0 writes `path`'s data to a temporary file of its own, then removes it."""
    fd, tmp = tempfile.mkstemp(prefix=".rank.", suffix=Path(path).suffix if suffix is None else suffix)
    os.close(fd)
    try:
        yield Path(tmp)
    finally:
        discard(tmp)


def _write_error(path, err: OSError) -> OSError:
    if isinstance(err, (OutputWriteError, IsADirectoryError)):
        return err
    return OutputWriteError(err.errno, err.strerror or str(err), os.fspath(path))


def write_atomically(path, write, mode: str = "w", *, fsync: bool = False) -> None:
    """Call ``write(file)`` on a temporary file opened with `mode` and install it at `path`.

    A crash, an interrupt or a full disk leaves `path` as it was (absent or the previous
    complete file).
    """
    with replacing(path, fsync=fsync) as tmp:
        with open(tmp, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as fh:
            write(fh)


def _problem(path) -> str | None:
    """Why `path` cannot be written, or None."""
    target = Path(path)
    real = _real(target)
    if real.is_dir():
        return "is a directory"
    parent = real.parent
    if not parent.is_dir():
        shown = target.parent if str(target.parent) else Path(".")
        return f"directory {str(shown)!r} does not exist"
    if real.exists():
        return None if os.access(real, os.W_OK) else "is not writable"
    try:
        _probe(parent)
    except OSError as err:
        return f"directory {str(parent)!r} is not writable ({err.strerror})"
    return None


def _probe(folder) -> None:
    """Make and remove a file in `folder`: the only test that sees read-only mounts and ACLs
    as the write will."""
    fd, probe = tempfile.mkstemp(prefix=".probe.", dir=folder)
    os.close(fd)
    os.unlink(probe)


def check_outputs(outputs) -> None:
    """Refuse, before any work, outputs that cannot be written: a mapping option -> path
    (None: not asked for). Raises OutputError naming the option for a directory, a missing
    or unwritable folder, an unwritable file, an empty path, or two options that reach one
    file (also through symbolic links); devices and FIFOs may be shared."""
    seen: dict[Path, str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        if os.fspath(path) == "":  # names no file: refused now, not found out after the run
            raise OutputError(f"`{option}` must be a file path; got ''")
        reason = _problem(path)
        if reason:
            raise OutputError(f"`{option}` {str(path)!r} {reason}")
        real = _real(path)
        if real in seen and not _is_stream(real):
            raise OutputError(f"`{seen[real]}` and `{option}` name the same file {str(path)!r}; "
                              "give each output its own file")
        seen[real] = option


def save_figure(fig, path, **kwargs) -> None:
    """``fig.savefig`` through :func:`replacing`; the format is the suffix of `path`
    (matplotlib's default format if it has none)."""
    fmt = kwargs.pop("format", None) or Path(path).suffix.lstrip(".").lower() or None
    if fmt is None:
        import matplotlib

        fmt = matplotlib.rcParams["savefig.format"]
    with replacing(path) as tmp:
        fig.savefig(tmp, format=fmt, **kwargs)


def writable_folder(option: str, path) -> Path:
    """Create the folder `path` if needed and check that files can be made in it, before any
    work; OutputError naming `option` otherwise (made and checked by rank 0 under an MPI launcher,
    every rank taking its verdict)."""
    if __package__:
        from .mpi_ranks import same_verdict

        return same_verdict(lambda: _writable_folder(option, path), OutputError) or Path(path)
    return _writable_folder(option, path)


def _writable_folder(option: str, path) -> Path:
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"`{option}` must be a directory; got the file {str(folder)!r}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        _probe(folder)
    except OSError as err:
        raise OutputError(f"`{option}` {str(folder)!r} is not a writable directory ({err.strerror})") from None
    return folder


def write_json(summary, path):
    """Write a JSON summary atomically (never half-written)."""
    path = Path(path)
    if _writes_here():
        path.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(summary, indent=1)
    write_atomically(path, lambda fh: fh.write(text))
