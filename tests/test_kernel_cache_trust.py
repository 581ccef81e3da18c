"""The kernel cache (icidr_pde.kernel_cache): the suite's own folder, unusable and untrusted
folders, files checked against the hash in their names, planted files never run, pruning, and
``icidr-pde cache {info,clear}`` (issues 22 and 26)."""

import errno
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from icidr_pde import cli, kernel_cache
from icidr_pde.rheology import codegen

#: one worker under pytest-xdist: the module fixture (a native library compiled in a cache of its own)
#: is built once, not once per worker
pytestmark = pytest.mark.xdist_group("kernel_cache_trust")

OTHER_UID = 65534  # nobody: a second user, for the files a test plants


@pytest.fixture
def cache_at(monkeypatch):
    """point(path): make `path` the NUMBA_CACHE_DIR of this process; returns the kernel folder."""
    def point(path):
        monkeypatch.setenv("NUMBA_CACHE_DIR", str(path))
        kernel_cache._reset()
        return Path(path) / "icidr_pde_kernels"

    yield point
    monkeypatch.undo()
    kernel_cache._reset()


def probe(tag, source="VALUE = 42\n"):
    """A generated module of kind 'probe' (a key of its own per test)."""
    return codegen._load("probe", str(tag), lambda: source)


def planted_name(tag, payload: bytes, ext=".py"):
    """The name under which `payload` passes for the probe kernel `tag` (hash of its bytes included)."""
    return f"{kernel_cache.stem('probe', codegen._digest(str(tag)))}.{kernel_cache.digest(payload)}{ext}"


def payload(marker: Path) -> bytes:
    return f"open({str(marker)!r}, 'w').write('ran')\nVALUE = 666\n".encode()


def test_the_suite_never_writes_into_the_users_cache(test_kernel_cache):
    assert kernel_cache.folder() == Path(test_kernel_cache) / "icidr_pde_kernels"
    assert not str(kernel_cache.folder()).startswith(os.path.expanduser("~"))
    child = subprocess.run([sys.executable, "-c", "from icidr_pde import kernel_cache; print(kernel_cache.folder())"],
                           capture_output=True, text=True, check=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    assert child.stdout.strip() == str(kernel_cache.folder())  # subprocesses inherit it


def test_cache_folder_is_created_private(cache_at, tmp_path):
    folder = cache_at(tmp_path)
    module = probe(tmp_path)
    assert module.VALUE == 42 and Path(module.__file__).parent == folder
    assert (folder.stat().st_mode & 0o777) == 0o700
    assert (Path(module.__file__).stat().st_mode & 0o077) == 0


def test_a_folder_readable_by_others_is_made_private(cache_at, tmp_path):
    """A cache made before it was private (0755) is kept and closed to others."""
    folder = cache_at(tmp_path)
    folder.mkdir(parents=True, mode=0o755)
    folder.chmod(0o755)
    module = probe(tmp_path)
    assert Path(module.__file__).parent == folder
    assert (folder.stat().st_mode & 0o777) == 0o700
    assert (Path(module.__file__).stat().st_mode & 0o077) == 0


# --- unusable folders (26.8) ----------------------------------------------------------------


def fell_back(capsys, where, reason):
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "not used" in line]
    assert len(lines) == 1, err
    assert str(where) in lines[0] and reason in lines[0] and "private temporary folder" in lines[0], lines[0]
    return lines[0]


def test_xdg_cache_home_a_file_falls_back_to_a_private_folder(monkeypatch, cache_at, tmp_path, capsys):
    cache_at(tmp_path)
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    (tmp_path / "xdg").write_text("a file")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    kernel_cache._reset()
    assert probe(tmp_path).VALUE == 42
    fell_back(capsys, tmp_path / "xdg" / "icidr_pde" / "kernels", "Not a directory")
    assert not str(kernel_cache.folder()).startswith(str(tmp_path))


def test_no_home_directory_falls_back(monkeypatch, cache_at, tmp_path, capsys):
    cache_at(tmp_path)
    for name in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME", "HOME"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(os.path, "expanduser", lambda path: path)  # no passwd entry either
    kernel_cache._reset()
    assert probe(tmp_path).VALUE == 42
    fell_back(capsys, "~", "HOME is not set")
    assert not Path("~").exists()


@pytest.mark.parametrize("fault", ["read-only", "full disk"])
def test_a_folder_that_cannot_be_written_falls_back_and_leaves_no_file(monkeypatch, cache_at, tmp_path, capsys, fault):
    folder = cache_at(tmp_path)
    kernel_cache.folder()
    if fault == "read-only":  # root ignores mode bits: the error a read-only folder gives
        mkstemp = tempfile.mkstemp

        def refuse(*args, dir=None, **kwargs):
            if Path(dir) == folder:
                raise PermissionError(errno.EACCES, "Permission denied", str(dir))
            return mkstemp(*args, dir=dir, **kwargs)

        monkeypatch.setattr(tempfile, "mkstemp", refuse)
        reason = "Permission denied"
    else:
        link = os.link

        def full(src, dst, *args, **kwargs):
            if Path(dst).parent == folder:
                raise OSError(errno.ENOSPC, "No space left on device")
            return link(src, dst, *args, **kwargs)

        monkeypatch.setattr(os, "link", full)
        reason = "No space left on device"
    assert probe(tmp_path).VALUE == 42
    fell_back(capsys, folder, reason)
    assert sorted(p.name for p in folder.iterdir()) == ["__pycache__"]  # no 0-byte temporary file left


# --- untrusted folders and files (26.20) ----------------------------------------------------


def test_a_folder_writable_by_others_is_refused_and_its_files_never_run(cache_at, tmp_path, capsys):
    folder = cache_at(tmp_path)
    folder.mkdir(parents=True)
    marker = tmp_path / "ran"
    (folder / planted_name(tmp_path, payload(marker))).write_bytes(payload(marker))
    folder.chmod(0o777)
    assert probe(tmp_path).VALUE == 42
    assert not marker.exists()
    fell_back(capsys, folder, "writable by group or others (mode 0777)")


def test_a_folder_owned_by_another_user_is_refused(cache_at, tmp_path, capsys):
    folder = cache_at(tmp_path)
    folder.mkdir(parents=True, mode=0o700)
    os.chown(folder, OTHER_UID, OTHER_UID)
    assert probe(tmp_path).VALUE == 42
    fell_back(capsys, folder, f"owned by uid {OTHER_UID}")


@pytest.mark.parametrize("how", ["owned by another user", "writable by others"])
def test_a_planted_module_is_not_run(cache_at, tmp_path, capsys, how):
    """A payload under the very name (and the hash of its own bytes) the kernel would have."""
    folder = cache_at(tmp_path)
    kernel_cache.folder()
    marker = tmp_path / "ran"
    planted = folder / planted_name(tmp_path, payload(marker))
    planted.write_bytes(payload(marker))
    if how == "owned by another user":
        os.chown(planted, OTHER_UID, OTHER_UID)
    else:
        planted.chmod(0o666)
    kernel_cache._reset()
    assert probe(tmp_path).VALUE == 42
    assert not marker.exists()
    fell_back(capsys, planted, f"owned by uid {OTHER_UID}" if how == "owned by another user" else "mode 0666")


def test_a_symlink_in_the_cache_is_not_followed(cache_at, tmp_path, capsys):
    folder = cache_at(tmp_path)
    kernel_cache.folder()
    marker = tmp_path / "ran"
    elsewhere = tmp_path / "evil.py"
    elsewhere.write_bytes(payload(marker))
    (folder / planted_name(tmp_path, payload(marker))).symlink_to(elsewhere)
    kernel_cache._reset()
    assert probe(tmp_path).VALUE == 42
    assert not marker.exists()
    assert "not used" in capsys.readouterr().err


def test_temporary_files_are_not_predictable_and_follow_no_symlink(cache_at, tmp_path):
    """The old `.NAME.<pid>.tmp` scheme wrote through a symlink planted at that name (26.21)."""
    folder = cache_at(tmp_path)
    kernel_cache.folder()
    victim = tmp_path / "victim"
    victim.write_text("precious")
    text = b"VALUE = 42\n"
    name = planted_name(tmp_path, text)
    for guess in (f".{name}.{os.getpid()}.tmp", f".{name.split('.')[0]}.py.{os.getpid()}.tmp"):
        (folder / guess).symlink_to(victim)
    assert probe(tmp_path).VALUE == 42
    assert victim.read_text() == "precious"
    with kernel_cache.scratch(".c") as a, kernel_cache.scratch(".c") as b:
        assert a != b and a.parent == folder and not a.is_symlink()


# --- corrupted files (26.9) -----------------------------------------------------------------


def test_a_truncated_module_is_rebuilt(cache_at, tmp_path, capsys):
    cache_at(tmp_path)
    source = "def f(x):\n    return x + 1\n\nVALUE = f(41)\n"
    path = Path(probe(tmp_path, source).__file__)
    path.write_bytes(path.read_bytes()[:20])  # SyntaxError if imported
    name = path.name.split(".")[0]
    codegen._MODULES.pop(name)
    sys.modules.pop(name)
    kernel_cache._reset()
    assert probe(tmp_path, source).VALUE == 42
    assert "do not match the hash in its name" in capsys.readouterr().err
    assert path.read_bytes() == source.encode()


NUMBA_CHILD = r"""
import sys
from icidr_pde.rheology import codegen
m = codegen._load("probe", sys.argv[1], lambda: "from numba import njit\n\n@njit(cache=True)\ndef f(x):\n    return x + 1\n")
print(m.f(41))
"""


def test_corrupt_numba_files_are_recompiled(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), PYTHONPATH=os.pathsep.join(sys.path))

    def child():
        proc = subprocess.run([sys.executable, "-c", NUMBA_CHILD, "numba probe"], capture_output=True, text=True, env=env)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.split() == ["42"]
        return proc.stderr

    child()
    numba_files = sorted((tmp_path / "icidr_pde_kernels" / "__pycache__").glob("*.nb[ic]"))
    assert {p.suffix for p in numba_files} == {".nbi", ".nbc"}  # numba's files are in the kernel folder
    for path in numba_files:
        path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2] if path.suffix == ".nbc" else b"\x80\x05junk")
    assert "recompiling" in child()  # an UnpicklingError before
    assert "recompiling" not in child()  # rewritten


# --- the native library (26.9, 26.18, 26.20) ------------------------------------------------

RUN = ["run", "--rheology", "icidr", "--scene", "sine", "--t-end", "0.1", "--no-progress", "--engine", "native"]


def run_native(cache, **env):
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path), **env)
    return subprocess.run([sys.executable, "-m", "icidr_pde.cli", *RUN], capture_output=True, text=True,
                          env=environment, timeout=600)


@pytest.fixture(scope="module")
def native_cache(tmp_path_factory):
    """A kernel cache holding the native library of icidr (compiled once for these tests)."""
    cache = tmp_path_factory.mktemp("native")
    proc = run_native(cache)
    assert proc.returncode == 0 and "py-pde" not in proc.stderr, proc.stderr
    return cache


def copy_of(native_cache, tmp_path):
    shutil.copytree(native_cache, tmp_path / "cache", symlinks=True)
    folder = tmp_path / "cache" / "icidr_pde_kernels"
    (library,) = folder.glob("*_native_*.so")
    return tmp_path / "cache", library


def evil_library(tmp_path) -> bytes:
    """A shared library whose constructor writes the file $ICIDR_TEST_MARKER."""
    source = tmp_path / "evil.c"
    source.write_text('#include <stdio.h>\n#include <stdlib.h>\n'
                      '__attribute__((constructor)) static void planted(void) {\n'
                      '  FILE *f = fopen(getenv("ICIDR_TEST_MARKER"), "w"); if (f) { fputs("ran", f); fclose(f); }\n}\n')
    subprocess.run(["gcc", "-shared", "-fPIC", "-o", str(tmp_path / "evil.so"), str(source)], check=True)
    return (tmp_path / "evil.so").read_bytes()


def rebuilt(proc, library, good: bytes):
    assert proc.returncode == 0, proc.stderr
    assert "py-pde" not in proc.stderr, proc.stderr  # the native engine ran
    assert "compiling native kernels" in proc.stderr
    assert library.read_bytes() == good  # the compiler's output is the same bytes for the same C text


@pytest.mark.parametrize("damage", ["truncated", "garbage"])
def test_a_damaged_library_is_rebuilt(native_cache, tmp_path, damage):
    """Truncated: SIGBUS before; garbage: every later run fell back and it was never rebuilt."""
    cache, library = copy_of(native_cache, tmp_path)
    good = library.read_bytes()
    library.write_bytes(good[: len(good) // 2] if damage == "truncated" else os.urandom(len(good)))
    proc = run_native(cache)
    rebuilt(proc, library, good)
    assert "do not match the hash in its name" in proc.stderr


def test_a_swapped_library_is_not_loaded(native_cache, tmp_path):
    cache, library = copy_of(native_cache, tmp_path)
    good = library.read_bytes()
    library.write_bytes(evil_library(tmp_path))
    marker = tmp_path / "ran"
    rebuilt(run_native(cache, ICIDR_TEST_MARKER=str(marker)), library, good)
    assert not marker.exists()


def test_a_library_planted_by_another_user_is_not_loaded(native_cache, tmp_path):
    cache, library = copy_of(native_cache, tmp_path)
    evil = evil_library(tmp_path)
    library.unlink()
    planted = library.with_name(f"{library.name.split('.')[0]}.{kernel_cache.digest(evil)}.so")
    planted.write_bytes(evil)
    os.chown(planted, OTHER_UID, OTHER_UID)
    marker = tmp_path / "ran"
    proc = run_native(cache, ICIDR_TEST_MARKER=str(marker))
    assert proc.returncode == 0 and "py-pde" not in proc.stderr, proc.stderr
    assert not marker.exists()
    assert f"owned by uid {OTHER_UID}" in proc.stderr and "private temporary folder" in proc.stderr


def test_a_planted_c_file_is_never_compiled(native_cache, tmp_path):
    cache, library = copy_of(native_cache, tmp_path)
    library.unlink()
    stem = library.name.split(".")[0]
    planted = '#error "the planted C file was compiled"\n'
    for name in (f"{stem}.c", f"{stem}.{kernel_cache.digest(planted.encode())}.c",
                 stem.replace(f"{kernel_cache.version()}_native", "native") + ".c"):
        (library.parent / name).write_text(planted)
    proc = run_native(cache)
    assert proc.returncode == 0 and "py-pde" not in proc.stderr, proc.stderr
    assert library.is_file()


@pytest.mark.parametrize("cc, says", [("/bin/false", "failed (exit status 1) with no message"),
                                      ("/usr/bin/true", "exited 0 but wrote no library")])
def test_a_compiler_that_fails_says_so_in_one_line(monkeypatch, cache_at, tmp_path, cc, says):
    from icidr_pde.native import build
    from icidr_pde.rheology import RHEOLOGIES, SHEAR_CELL

    folder = cache_at(tmp_path)
    monkeypatch.setenv("CC", cc)
    with pytest.raises(build.NativeUnavailable) as err:
        build.library(RHEOLOGIES["icidr"](), SHEAR_CELL)
    assert str(err.value) == f"the C compiler {cc} {says}"
    assert sorted(p.name for p in folder.iterdir()) == ["__pycache__"]  # no C file, no empty library


# --- pruning, info, clear (22.5) ------------------------------------------------------------


def plant_stale(folder, age_s):
    """Files of another code version (and of the naming before it), a temporary file, `age_s` old."""
    names = ["icidr_pde_000000000000_law_0123.4567.py", "icidr_pde_kernels_fd_89ab.py", "icidr_pde_native_cdef.so",
             ".icidr_pde-x1y2z3.so.tmp"]
    paths = [folder / n for n in names] + [folder / "__pycache__" / "icidr_pde_000000000000_law_0123.4567.f-3.py311.nbi"]
    for path in paths:
        path.write_bytes(b"old")
        os.utime(path, (time.time() - age_s,) * 2)
    return paths


def test_kernels_of_other_code_versions_are_pruned_when_a_kernel_is_written(cache_at, tmp_path):
    folder = cache_at(tmp_path)
    kernel_cache.folder()
    old = plant_stale(folder, 2 * kernel_cache.PRUNE_AFTER_S)
    recent = folder / "icidr_pde_111111111111_law_89.ab.py"  # may still be in use by a running process
    recent.write_bytes(b"recent")
    os.utime(recent, (time.time() - 60,) * 2)
    assert probe(tmp_path).VALUE == 42
    assert not any(p.exists() for p in old)
    assert recent.exists()
    assert len(list(folder.glob(f"icidr_pde_{kernel_cache.version()}_probe_*.py"))) == 1


def test_cache_info_and_clear(cache_at, tmp_path, capsys):
    folder = cache_at(tmp_path)
    probe(tmp_path)
    plant_stale(folder, 0)
    capsys.readouterr()
    assert cli.main(["cache", "info", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["folder"] == str(folder) and out["refused"] is None
    assert (out["kernels"], out["current"], out["stale"]) == (4, 1, 3)  # the probe; law, fd and native of old
    assert out["files"] == 6 and out["bytes"] == sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
    assert cli.main(["cache", "info"]) == 0
    assert f"kernel cache: {folder}" in capsys.readouterr().out
    assert cli.main(["cache", "clear", "--stale"]) == 0
    assert "removed 4 stale files" in capsys.readouterr().out  # not the temporary file another process may be writing
    assert sorted(p.name for p in folder.iterdir() if p.is_file()) == [".icidr_pde-x1y2z3.so.tmp",
                                                                        Path(probe(tmp_path).__file__).name]
    assert cli.main(["cache", "clear"]) == 0
    assert "removed 1 file " in capsys.readouterr().out  # nor by a full clear (issue 42, item 18)
    assert [p.name for p in folder.rglob("*") if p.is_file()] == [".icidr_pde-x1y2z3.so.tmp"]


def test_a_killed_compile_leaves_no_compiler_running(tmp_path):
    """The compiler dies with the run (26.9: an orphaned compiler went on writing into the cache)."""
    import signal

    compiler = tmp_path / "slow-cc"
    pid_file = tmp_path / "cc.pid"
    compiler.write_text(f"#!/bin/sh\necho $$ > {pid_file}\nexec sleep 60\n")
    compiler.chmod(0o755)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=os.pathsep.join(sys.path),
               CC=str(compiler))
    run = subprocess.Popen([sys.executable, "-m", "icidr_pde.cli", *RUN], env=env, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not (pid_file.exists() and pid_file.read_text().strip()) and time.monotonic() < deadline:
        assert run.poll() is None
        time.sleep(0.1)
    pid = int(pid_file.read_text())
    run.send_signal(signal.SIGKILL)
    run.wait()

    def alive():
        try:
            return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
        except FileNotFoundError:
            return False

    deadline = time.monotonic() + 10
    while alive() and time.monotonic() < deadline:
        time.sleep(0.1)
    if alive():
        os.kill(pid, signal.SIGKILL)
        raise AssertionError("the compiler outlived the killed run")
