"""The kernel cache: one private folder holding the generated kernels of this user.

What it holds: the Python modules :mod:`icidr_pde.rheology.codegen` generates from a law (and
numba's compiled code of their functions, in ``__pycache__``), the native engine's shared
libraries (:mod:`icidr_pde.native.build`) and the notes of laws the C printer refuses. Every
other module asks this one for the folder, reads a kernel with :func:`read` and writes one with
:func:`store` or :func:`build`; ``icidr-pde cache {info,clear}`` (:mod:`icidr_pde.cli.cache`)
shows and empties it.

**Where.** ``$NUMBA_CACHE_DIR/icidr_pde_kernels`` when NUMBA_CACHE_DIR is set, else
``$XDG_CACHE_HOME/icidr_pde/kernels`` (an absolute XDG_CACHE_HOME only, as the XDG rules say),
else ``~/.cache/icidr_pde/kernels``. numba's files of these kernels go to the folder's
``__pycache__`` whatever NUMBA_CACHE_DIR says (:func:`numba_setup`), so that one folder holds
everything and one trust check covers it.

**Names.** A kernel is a *stem*, ``icidr_pde_<version>_<kind>_<key>``: `version` is a hash of
this package's kernel-generating sources (:func:`version`), `key` a hash of everything the
kernel's text is made from (computed by the caller before any sympy work). A file is
``<stem>.<digest><ext>``, the digest being the hash of the file's own bytes: the name promises
the content, and a file whose bytes do not hash to its name (truncated, overwritten) is removed
and rebuilt. Files are never rewritten: written whole under a :mod:`tempfile` name in the folder
(``O_EXCL``, mode 0600), then hard-linked into place.

**Trust** (docs/security.md): the folder is created 0700; a folder or a file owned by another
user, or writable by group or others, is refused with one line on stderr, and the run goes on in
a private temporary folder (removed at exit; kernels are then compiled in every run). So is a
folder that cannot be used (not a directory, read-only, full disk, no home directory).

**Pruning.** When a kernel is written, files of other code versions older than
:data:`PRUNE_AFTER_S` (and temporary files left by killed processes) are removed: a new
version's first compilation clears the previous version's kernels.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import pathlib
import stat
import sys
import threading
import time

__all__ = ["KernelCacheError", "untrusted", "digest", "version", "sympy_version", "folder", "stem", "read", "store",
           "build", "scratch", "numba_setup", "numba_saves_may_fail", "prune", "info", "clear",
           "PRUNE_AFTER_S"]

PREFIX = "icidr_pde_"
TEMP_PREFIX = ".icidr_pde-"
PRUNE_AFTER_S = 3600.0  # a file of another version younger than this may still be used by a running process
#: folder of the package ("*": every folder there, each cell's) -> endings of the files read
_VERSION_SOURCES = {"rheology": (".py",), "native": (".py", ".c", ".h"), "cells/*": (".c", ".h"),
                    "cells/*/templates": (".py",), ".": ("kernel_cache.py",)}
_LOCK = threading.RLock()
_STATE: dict = {}  # folder, private, listing, version, pruned, numba


class KernelCacheError(OSError):
    """No folder can hold the kernels (the message, one line, says what and where)."""


class _Refused(Exception):
    """The cache folder or a file in it cannot be used or trusted (the reason is the message)."""


def digest(*parts: str | bytes) -> str:
    """Hash of `parts` (text or bytes), 20 hex digits: the key and content digests of the names."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part if isinstance(part, bytes) else part.encode())
        h.update(b"\0")
    return h.hexdigest()[:20]


def sympy_version() -> str:
    """sympy's release.py, found without importing sympy or importlib.metadata (importing the latter
    is a start-up cost every run would pay: docs/performance.md, Start-up)."""
    import importlib.util

    spec = importlib.util.find_spec("sympy")
    release = pathlib.Path(spec.origin).with_name("release.py") if spec and spec.origin else None
    return release.read_text() if release is not None and release.is_file() else "?"


def version() -> str:
    """Hash of the sources every kernel is generated from (the laws, the printers, the templates, the
    native driver, this module), sympy's version and Python's: the code version of a kernel's name."""
    if "version" not in _STATE:
        root = os.path.dirname(os.path.abspath(__file__))
        parts = [sys.version, sympy_version()]
        for pattern, endings in _VERSION_SOURCES.items():  # os.listdir: pathlib's glob costs ms of start-up
            for sub in _folders(root, pattern):
                directory = os.path.join(root, sub)
                for name in sorted(n for n in os.listdir(directory) if n.endswith(endings)):
                    with open(os.path.join(directory, name), "rb") as f:
                        parts += [f"{sub}/{name}", f.read()]
        _STATE["version"] = digest(*parts)[:12]
    return _STATE["version"]


def _folders(root: str, pattern: str) -> list[str]:
    """The folders of `pattern` under `root`: itself, or with its "*" each folder there (sorted)."""
    if "*" not in pattern:
        return [pattern]
    head, _, tail = pattern.partition("*")
    parent = os.path.join(root, head)
    return [head + name + tail for name in sorted(os.listdir(parent))
            if not name.startswith(("_", ".")) and os.path.isdir(os.path.join(parent, name + tail))]


def stem(kind: str, key: str) -> str:
    """The stem of a kernel of `kind` whose inputs hash to `key` (see the module docstring)."""
    return f"{PREFIX}{version()}_{kind}_{key}"


# --- the folder -----------------------------------------------------------------------------


def configured() -> tuple[pathlib.Path | None, str]:
    """(the folder the environment names, or None; the setting it comes from)."""
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir:
        return pathlib.Path(numba_dir).absolute() / "icidr_pde_kernels", "NUMBA_CACHE_DIR"
    xdg = os.environ.get("XDG_CACHE_HOME")
    if xdg and os.path.isabs(xdg):
        return pathlib.Path(xdg) / "icidr_pde" / "kernels", "XDG_CACHE_HOME"
    home = os.path.expanduser("~")
    if not os.path.isabs(home):
        return None, "HOME"
    return pathlib.Path(home) / ".cache" / "icidr_pde" / "kernels", "HOME"


def untrusted(st: os.stat_result) -> str | None:
    """Why a file or folder with this status cannot be trusted, or None: owned by another user or
    writable by group or others (also the check of a dask scheduler file, which names a cluster
    trusted with the account: :mod:`icidr_pde.studies.distributed`)."""
    if st.st_uid != os.geteuid():
        return f"owned by uid {st.st_uid}, not by this user (uid {os.geteuid()})"
    if st.st_mode & 0o022:
        return f"writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def _check_file(st: os.stat_result) -> None:
    """_Refused unless `st` is that of a regular file this user owns and only this user can write."""
    if not stat.S_ISREG(st.st_mode):
        raise _Refused("not a regular file")
    reason = untrusted(st)
    if reason:
        raise _Refused(reason)


def _prepare(path: pathlib.Path) -> None:
    """Create `path` (0700) and its ``__pycache__`` if missing; raise _Refused if either is unusable."""
    for directory in (path, path / "__pycache__"):
        try:
            directory.mkdir(parents=True, exist_ok=True, mode=0o700)
            st = os.stat(directory)
        except OSError as err:
            raise _Refused(err.strerror or str(err)) from None
        if not stat.S_ISDIR(st.st_mode):
            raise _Refused("not a directory")
        reason = untrusted(st)
        if reason:
            raise _Refused(reason)
        if st.st_mode & 0o077:  # readable by others: a folder made before the cache was private
            with contextlib.suppress(OSError):
                os.chmod(directory, 0o700)
        if not os.access(directory, os.W_OK | os.X_OK):
            raise _Refused("not writable")


def folder() -> pathlib.Path:
    """The kernel folder of this process: the configured one, checked (see the module docstring),
    or a private temporary one."""
    with _LOCK:
        if "folder" not in _STATE:
            path, setting = configured()
            try:
                if path is None:
                    raise _Refused(f"{setting} is not set")
                _prepare(path)
                _use(path, private=False)
            except _Refused as err:
                _fall_back(path or "~", str(err))
        return _STATE["folder"]


def _use(path: pathlib.Path, private: bool) -> None:
    _STATE.update(folder=path, private=private, listing=None)


def _fall_back(where, reason: str) -> pathlib.Path:
    """Say in one line why `where` is not used, then use a private temporary folder."""
    import atexit
    import shutil
    import tempfile

    if _STATE.get("private"):
        raise KernelCacheError(f"kernel cache {where}: {reason}")
    try:
        path = pathlib.Path(tempfile.mkdtemp(prefix="icidr-pde-kernels-"))
        (path / "__pycache__").mkdir(mode=0o700)
    except OSError as err:
        raise KernelCacheError(f"kernel cache {where}: {reason}; no private temporary folder either: "
                               f"{err.strerror or err}") from None
    atexit.register(shutil.rmtree, path, ignore_errors=True)
    sys.stderr.write(f"icidr-pde: kernel cache {where} not used: {reason}; using the private temporary "
                     f"folder {path} (kernels are compiled again in every run)\n")
    sys.stderr.flush()
    _use(path, private=True)
    return path


def _listing() -> dict[str, list[str]]:
    """stem -> names of its files in the folder (listed once per process, kept up to date by writes)."""
    if _STATE.get("listing") is None:
        listing: dict[str, list[str]] = {}
        try:
            names = os.listdir(folder())
        except OSError:
            names = []
        for name in names:
            if name.startswith(PREFIX):
                listing.setdefault(name.split(".", 1)[0], []).append(name)
        _STATE["listing"] = listing
    return _STATE["listing"]


# --- reading and writing --------------------------------------------------------------------


def _read_trusted(path: pathlib.Path) -> bytes:
    """The bytes of the regular file `path` (not followed if a symlink); _Refused if not trusted."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    try:
        _check_file(os.fstat(fd))
        with os.fdopen(os.dup(fd), "rb") as f:
            return f.read()
    finally:
        os.close(fd)


def read(kernel: str, ext: str) -> tuple[pathlib.Path, bytes] | None:
    """(path, bytes) of the cached file of stem `kernel` ending in `ext` whose bytes hash to its name,
    or None. A file that does not is removed (one line on stderr); an untrusted one switches this
    process to a private temporary folder."""
    with _LOCK:
        for name in list(_listing().get(kernel, ())):
            if not name.endswith(ext) or name.count(".") != 1 + ext.count("."):
                continue
            path = folder() / name
            try:
                data = _read_trusted(path)
            except FileNotFoundError:
                _forget(kernel, name)
                continue
            except (_Refused, OSError) as err:  # a symlink gives ELOOP
                _fall_back(path, str(err) if isinstance(err, _Refused) else err.strerror)
                return None
            claimed = name[len(kernel) + 1:len(name) - len(ext)]
            if data and digest(data) == claimed:
                return path, data
            _discard(path, "empty" if not data else "its bytes do not match the hash in its name")
        return None


def _forget(kernel: str, name: str) -> None:
    names = _listing().get(kernel, [])
    if name in names:
        names.remove(name)


def _discard(path: pathlib.Path, why: str) -> None:
    sys.stderr.write(f"icidr-pde: kernel cache: removed {path} ({why}); it is rebuilt\n")
    sys.stderr.flush()
    with contextlib.suppress(OSError):
        path.unlink()
    _forget(path.name.split(".", 1)[0], path.name)


def store(kernel: str, ext: str, data: bytes) -> pathlib.Path:
    """Write `data` as the file of stem `kernel` ending in `ext` and return its path."""
    def write(tmp: pathlib.Path) -> None:
        with open(tmp, "wb") as f:
            f.write(data)

    return build(kernel, ext, write)


def build(kernel: str, ext: str, make) -> pathlib.Path:
    """Call ``make(tmp)`` to write a new file at the temporary path `tmp` (in the folder, created
    with O_EXCL, mode 0600), then publish it as the file of stem `kernel` ending in `ext` and return
    its path. A folder that cannot take the file (read-only, full disk) is given up for a private
    temporary one; `make` raising (e.g. a compiler error) publishes nothing. Exceptions of `make`
    pass through; a file `make` leaves empty is a KernelCacheError."""
    for _ in range(2):
        try:
            with scratch(ext + ".tmp") as tmp:
                make(tmp)
                data = _read_trusted(tmp)
                if not data:
                    raise KernelCacheError(f"nothing was written to {tmp}")
                return _publish(kernel, ext, tmp, data)
        except KernelCacheError:
            raise
        except OSError as err:
            if getattr(err, "filename", None) is not None and not str(err.filename).startswith(str(folder())):
                raise
            _fall_back(folder(), f"cannot write there: {err.strerror or err}")
        except _Refused as err:
            _fall_back(folder(), str(err))
    raise KernelCacheError(f"kernel cache {folder()}: cannot write {kernel}{ext}")


@contextlib.contextmanager
def scratch(suffix: str):
    """A new empty private temporary file in the kernel folder (O_EXCL, 0600), removed on exit: the
    path yielded is never one another user could have prepared."""
    import tempfile

    fd, name = tempfile.mkstemp(dir=folder(), prefix=TEMP_PREFIX, suffix=suffix)
    os.close(fd)
    path = pathlib.Path(name)
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            path.unlink()


def _publish(kernel: str, ext: str, tmp: pathlib.Path, data: bytes) -> pathlib.Path:
    path = tmp.with_name(f"{kernel}.{digest(data)}{ext}")
    try:
        os.link(tmp, path)  # atomic, and fails if another process was first (with the same bytes)
    except FileExistsError:
        pass
    except OSError as err:
        if err.errno in (errno.ENOSPC, errno.EROFS, errno.EDQUOT):
            raise
        if not path.exists():  # a file system without hard links
            os.replace(tmp, path)
    names = _listing().setdefault(kernel, [])
    if path.name not in names:
        names.append(path.name)
    if not _STATE.get("pruned"):
        _STATE["pruned"] = True
        prune()
    return path


# --- numba's files --------------------------------------------------------------------------


def _numba_owned(cache_path) -> bool:
    return str(cache_path) == str(folder() / "__pycache__")


def numba_setup() -> None:
    """Make numba keep the compiled code of the kernel modules in the folder's ``__pycache__``
    (whatever NUMBA_CACHE_DIR says), read its index and data files there only if trusted (a
    corrupt or untrusted file is a cache miss, recompiled and rewritten) and write them 0600.
    Idempotent; imports numba's caching module, so call it only where numba is used."""
    with _LOCK:
        if _STATE.get("numba"):
            return
        from numba.core import caching

        class KernelFolderLocator(caching.InTreeCacheLocator):
            """numba's in-tree locator, for the files of the kernel folder only. A kernel's name
            holds the hash of its bytes, so the name is its source stamp: the module runs from the
            bytes read, and a `cache clear` of another process that removes the file after they
            were read (numba's own locators then find no file and refuse to cache) changes nothing."""

            @classmethod
            def from_function(cls, py_func, py_file):
                if os.path.dirname(os.path.abspath(py_file)) != str(folder()):
                    return None
                self = cls(py_func, py_file)
                try:
                    self.ensure_cache_path()
                except OSError:
                    return None
                return self

            def get_source_stamp(self):
                return os.path.basename(self._py_file)

        caching.CacheImpl._locator_classes.insert(0, KernelFolderLocator)
        files = caching.IndexDataCacheFile
        load_index, load_data, open_for_write = files._load_index, files._load_data, files._open_for_write

        def _load_index(self):
            if not _numba_owned(self._cache_path):
                return load_index(self)
            try:
                _check_file(os.lstat(self._index_path))
                return load_index(self)
            except FileNotFoundError:
                return {}
            except Exception as err:  # noqa: BLE001 -- any unreadable index is a miss
                _numba_miss(self._index_path, err)
                return {}

        def _load_data(self, name):
            if not _numba_owned(self._cache_path):
                return load_data(self, name)
            path = self._data_path(name)
            try:
                _check_file(os.lstat(path))
                return load_data(self, name)
            except FileNotFoundError:
                raise
            except Exception as err:  # noqa: BLE001
                _numba_miss(path, err)
                raise OSError(str(err)) from None  # numba's load() takes OSError as a miss

        @contextlib.contextmanager
        def _open_for_write(self, filepath):
            with open_for_write(self, filepath) as f:
                if _numba_owned(self._cache_path):
                    os.fchmod(f.fileno(), 0o600)
                yield f

        files._load_index, files._load_data, files._open_for_write = _load_index, _load_data, _open_for_write
        _STATE["numba"] = True
    numba_saves_may_fail()




def numba_saves_may_fail() -> None:
    """Make a failure to save numba's compiled code (a full disk, a read-only folder under
    NUMBA_CACHE_DIR or beside the package) one line on stderr, once per process, instead of an
    exception out of the first call of a function: the code compiled is used all the same, only
    not kept for the next run. Covers every cached function, the package's own (``engines/``,
    which call this at import) and the kernels' (:func:`numba_setup`). Idempotent."""
    with _LOCK:
        if _STATE.get("numba_saves"):
            return
        from numba.core import caching

        save_overload = caching.Cache.save_overload

        def tolerant_save_overload(self, sig, data):
            try:
                save_overload(self, sig, data)
            except OSError as err:
                if not _STATE.get("numba_save_failed"):
                    _STATE["numba_save_failed"] = True
                    where = getattr(self, "_cache_path", None) or getattr(err, "filename", None) or "?"
                    sys.stderr.write(f"icidr-pde: numba cache {where}: compiled code not saved "
                                     f"({err.strerror or err}); it is compiled again in every run\n")
                    sys.stderr.flush()

        caching.Cache.save_overload = tolerant_save_overload
        _STATE["numba_saves"] = True


def _numba_miss(path, err) -> None:
    what = str(err) if isinstance(err, _Refused) else f"unreadable: {type(err).__name__}"
    sys.stderr.write(f"icidr-pde: kernel cache: numba file {path} not used ({what}); recompiling\n")
    sys.stderr.flush()


# --- pruning, info, clear -------------------------------------------------------------------


def _entries(path: pathlib.Path):
    """(path, stat, current) of every file of this package in `path` and its ``__pycache__``."""
    current = f"{PREFIX}{version()}_"
    for directory in (path, path / "__pycache__"):
        try:
            names = os.listdir(directory)
        except OSError:
            continue
        for name in names:
            if name.startswith(PREFIX) or name.startswith(TEMP_PREFIX):
                file = directory / name
                with contextlib.suppress(OSError):
                    yield file, os.lstat(file), name.startswith(current)


def _temporary(name: str) -> bool:
    """Whether `name` is a file being written: this module's (:func:`scratch`) or numba's
    (``<index or data file>.tmp.<uuid>``, renamed into place when whole)."""
    return name.startswith(TEMP_PREFIX) or ".tmp." in name


def prune(older_than: float = PRUNE_AFTER_S, stale_only: bool = True, path: pathlib.Path | None = None):
    """Remove the files of other code versions (and temporary files older than :data:`PRUNE_AFTER_S`)
    in the folder last modified more than `older_than` seconds ago; every file of this package if not
    `stale_only`. A temporary file younger than :data:`PRUNE_AFTER_S` is never removed: another
    process may be writing it, and would fail without it.
    Returns (files removed, bytes)."""
    path = folder() if path is None else path
    now, count, size = time.time(), 0, 0
    for file, st, current in list(_entries(path)):
        age = now - st.st_mtime
        in_progress = _temporary(file.name) and age < PRUNE_AFTER_S  # another process writing it
        if in_progress or (stale_only and current) or age < older_than:
            continue
        try:
            file.unlink()
        except OSError:
            continue
        count, size = count + 1, size + st.st_size
    if path == _STATE.get("folder"):
        _STATE["listing"] = None
    return count, size


def info() -> dict:
    """Where the configured folder is, whether it is used (or why not), its size and its kernels
    (stems), those of this code version and the stale ones."""
    path, setting = configured()
    out = {"folder": str(path) if path else None, "setting": setting, "refused": None, "version": version(),
           "files": 0, "bytes": 0, "kernels": 0, "current": 0, "stale": 0, "stale_bytes": 0}
    if path is None:
        out["refused"] = f"{setting} is not set"
        return out
    try:
        st = os.stat(path)
        out["refused"] = untrusted(st) or (None if stat.S_ISDIR(st.st_mode) else "not a directory")
    except FileNotFoundError:
        return out
    except OSError as err:
        out["refused"] = err.strerror
        return out
    kernels: dict[str, bool] = {}
    for file, st, current in _entries(path):
        out["files"] += 1
        out["bytes"] += st.st_size
        if not current:
            out["stale_bytes"] += st.st_size
        if file.parent == path and not file.name.startswith(TEMP_PREFIX):
            kernels[file.name.split(".", 1)[0]] = current
    out["kernels"] = len(kernels)
    out["current"] = sum(kernels.values())
    out["stale"] = out["kernels"] - out["current"]
    return out


def clear(stale_only: bool = False) -> tuple[pathlib.Path | None, int, int]:
    """Remove every file of this package from the configured folder (those of other code versions
    only with `stale_only`), but for the files other processes are writing (:func:`prune`): a run
    that is compiling while the cache is cleared goes on (its kernels are in memory, and files it
    publishes later are new files). Returns (folder, files removed, bytes); a folder owned by
    another user is left alone (ValueError)."""
    path, setting = configured()
    if path is None or not path.is_dir():
        return path, 0, 0
    st = os.stat(path)
    if st.st_uid != os.geteuid():
        raise ValueError(f"kernel cache {path} is owned by uid {st.st_uid}, not by this user: not cleared")
    return (path, *prune(older_than=0.0, stale_only=stale_only, path=path))


def _reset() -> None:
    """Forget the folder chosen and the listing (the environment changed: tests)."""
    with _LOCK:
        kept = {k: _STATE[k] for k in ("numba", "numba_saves") if _STATE.get(k)}
        _STATE.clear()
        _STATE.update(kept)
