"""Regression tests of issue 42 (hardening, round 3), items 1-3 and 5-10.

Each test reproduces one defect through the command line (``icidr_pde.cli.main`` in process,
or a subprocess where a resource limit, a signal or the exit status is the point) or the public
function that holds the fix. Tests that would start processes or allocate without bound on the
code before its fix are written so that the unfixed code fails them safely (a stub that
refuses to start a pool, a subprocess under a memory limit).
"""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from icidr_pde import cli

ROOT = Path(__file__).resolve().parents[1]


def _bad_input(capsys, argv, option):
    """Run the CLI in process: exit 2 and one error line (after argparse's usage) naming
    `option`, no traceback."""
    with pytest.raises(SystemExit) as info:
        raise SystemExit(cli.main(argv))
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    lines = [line for line in err.strip().splitlines() if line.startswith("icidr-pde")]
    assert len(lines) == 1 and option in lines[0], err
    assert "Traceback" not in err and "Error:" not in err
    return lines[0]


def _python(code: str, *, memory: int | None = None, timeout: float = 120, env=None):
    """Run `code` in a fresh interpreter (with an address-space limit of `memory` bytes)."""
    preexec = None
    if memory is not None:
        import resource

        def preexec():
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=preexec, cwd=ROOT,
                          env=dict(os.environ, PYTHONPATH=str(ROOT), **(env or {})))


# --- 7. --workers and --jobs have an upper bound ----------------------------------------------


@pytest.fixture
def no_processes(monkeypatch):
    """Starting a process pool or a LocalCluster fails the test (instead of starting thousands)."""
    def refuse(*args, **kwargs):
        raise AssertionError("a pool of worker processes was started")

    monkeypatch.setattr(multiprocessing, "get_context", refuse)
    try:
        import distributed
    except ImportError:
        return
    monkeypatch.setattr(distributed, "LocalCluster", refuse)


@pytest.mark.parametrize("option", ["--jobs", "--workers"])
def test_a_process_count_beyond_the_machine_is_refused(no_processes, capsys, option):
    from icidr_pde.studies.parallel import max_processes

    line = _bad_input(capsys, ["tstar", "--N", "21", "--t-end", "0.001", "--no-progress", option, "100000"], option)
    assert f"[1, {max_processes()}]" in line and "100000" in line


def test_run_cases_refuses_a_pool_beyond_the_machine(no_processes):
    from icidr_pde.studies.parallel import max_processes, run_cases
    from icidr_pde.validation import ParameterError

    with pytest.raises(ParameterError, match=r"`jobs` must be an integer in \[1, \d+\]; got 100000"):
        list(run_cases(abs, [1, 2], 100000, False))
    assert max_processes() >= 4  # a machine of one core may still run 4 workers


# --- 9. tstar --N: the number of cases and each N bounded before a range is expanded -----------


@pytest.mark.parametrize("text, expected", [
    ("4:200000:1", r"every `--N` must be in \[4, 100000\]"),
    ("4:99999:1,5:99999:1", r"at most 10000 cases; got 199991"),
    ("21,100001", r"every `--N` must be in \[4, 100000\]"),
])
def test_tstar_N_is_bounded(capsys, monkeypatch, text, expected):
    import re

    from icidr_pde.cli import tstar as tstar_cli

    def no_sweep(*args, **kwargs):
        raise AssertionError("the sweep was started")

    monkeypatch.setattr(tstar_cli, "sweep", no_sweep)

    line = _bad_input(capsys, ["tstar", "--N", text, "--t-end", "0.001", "--no-progress", "--jobs", "1"], "--N")
    assert re.search(expected, line), line


def test_a_huge_N_range_is_refused_before_it_is_expanded():
    """Under a 1 GiB address-space limit: a list of 10^12 numbers cannot be built, so only a check
    on the range's ends and its counted length can answer."""
    done = _python("""
        from icidr_pde.studies.failure_time import parse_range
        try:
            parse_range("4:1000000000000:1")
        except ValueError as err:
            print("refused:", err)
        """, memory=1 << 30)
    assert done.returncode == 0 and "refused: every `N` must be in [4, 100000]" in done.stdout, done.stderr[-2000:]


def test_the_largest_sweep_is_accepted():
    from icidr_pde.studies.failure_time import parse_range

    assert parse_range("4:10003:1") == list(range(4, 10004))
    assert parse_range("4:100000:10") == list(range(4, 100001, 10))


# --- 2, 3. declarative laws: no complex numbers, no constant beyond a float's range ------------

#: half-rate law of examples/half_rate_law.toml with a factor {extra} in its yield function
_LAW = '''name = "{name}"
yield_function = "M * p * (k * I / Psi + 1 - k) * {extra}"
dilatancy_function = "M * (k * I / (4 * Psi) + 1 - k - Psi * (1 - 3 * k / 4) / I)"
[parameters]
k = 0.5
'''


@pytest.mark.parametrize("extra, token", [
    ("sqrt(-1)", "sqrt(-1)"),
    ("(1 + log(-1))", "log(-1)"),
    ("(-1)**(1/2)", "(-1)**(1/2)"),
    ("(-8)**(1/3) / 2", "(-8)**(1/3)"),   # sympy's principal root 1 + sqrt(3) i, written 2*(-1)**(1/3)
    ("sqrt(-phi) + 1", "sqrt(-phi)"),
])
def test_a_complex_law_formula_is_refused(tmp_path, capsys, extra, token):
    law = tmp_path / "complex.toml"
    law.write_text(_LAW.format(name="complex-law", extra=extra))
    for argv in (["law", "check", str(law)], ["run", "--rheology", str(law), "--N", "21", "--t-end", "0.001",
                                                 "--no-progress"]):
        line = _bad_input(capsys, argv, "yield_function")
        assert f"{token!r} is not allowed" in line and "complex" in line, line


def test_chained_powers_are_refused_before_they_are_built(tmp_path, capsys):
    """Each power within the +-64 cap, the chain 2^(64^4) = 2^16777216: refused at its first step
    beyond a float's range, before sympy multiplies it out (five levels took 22 s and 625 MB)."""
    law = tmp_path / "huge.toml"
    law.write_text(_LAW.format(name="huge-law", extra="((((2**64)**64)**64)**64) / 2**16777216"))
    line = _bad_input(capsys, ["law", "check", str(law)], "yield_function")
    assert "'(2**64)**64' is not allowed" in line and "1100 bits" in line, line


def test_constants_within_a_float_s_range_are_read_exactly():
    import sympy as sp

    from icidr_pde.rheology.declarative import parse_expression

    assert parse_expression("(2**15)**64", {}) == sp.Integer(2) ** 960
    assert parse_expression("(1/2)**64 * 3**(-64)", {}) == sp.Rational(1, 6**64)
    assert parse_expression("(-2)**3 + sqrt(4) + (-8)**(-1)", {}) == sp.Rational(-49, 8)
    with pytest.raises(ValueError, match="1100 bits"):
        parse_expression("(2**32)**64", {})


# --- 1, 8. a dask cluster: the scheduler file is trusted only as the kernel cache's files are;
# a result of the wrong shape and a port that never speaks dask are one line, exit 2 ------------

_TSTAR = ["tstar", "--N", "21", "--t-end", "0.001", "--no-progress", "--discretization", "fd"]


@pytest.fixture(scope="module")
def loopback_scheduler():
    """A dask scheduler on 127.0.0.1 with one worker thread in this process."""
    distributed = pytest.importorskip("distributed")
    import logging

    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None, silence_logs=logging.ERROR) as local:
        yield local.scheduler_address


def _scheduler_file(tmp_path, address, mode=0o600):
    import json

    path = tmp_path / "scheduler.json"
    path.write_text(json.dumps({"type": "Scheduler", "address": address}))
    os.chmod(path, mode)
    return path


def test_a_trusted_scheduler_file_runs_the_sweep(loopback_scheduler, tmp_path, capsys):
    path = _scheduler_file(tmp_path, loopback_scheduler)
    assert cli.main([*_TSTAR, "--scheduler", str(path)]) == 0
    assert "N=  21" in capsys.readouterr().out


def test_a_world_writable_scheduler_file_is_refused(loopback_scheduler, tmp_path, capsys):
    path = _scheduler_file(tmp_path, loopback_scheduler, mode=0o666)
    line = _bad_input(capsys, [*_TSTAR, "--scheduler", str(path)], "--scheduler")
    assert "writable by group or others (mode 0666)" in line and str(path) in line


@pytest.mark.skipif(os.geteuid() != 0, reason="giving a file to another uid needs root")
def test_a_scheduler_file_of_another_user_is_refused(loopback_scheduler, tmp_path, capsys):
    path = _scheduler_file(tmp_path, loopback_scheduler, mode=0o644)
    os.chown(path, 65534, 65534)
    line = _bad_input(capsys, [*_TSTAR, "--scheduler", str(path)], "--scheduler")
    assert f"owned by uid 65534, not by this user (uid {os.geteuid()})" in line


def test_a_task_result_of_the_wrong_shape_is_one_line(loopback_scheduler, tmp_path, capsys, monkeypatch):
    """A worker whose start-up replaced the task (``dask worker --preload``) returns what it likes:
    here an int where the sweep expects (index, failure_time dict)."""
    from icidr_pde.studies import parallel  # map_cases's task

    monkeypatch.setattr(parallel, "_task", lambda function, case: 0)
    line = _bad_input(capsys, [*_TSTAR, "--scheduler", loopback_scheduler], "--scheduler")
    assert "a task returned 0 (of type int)" in line
    monkeypatch.setattr(parallel, "_task", lambda function, case: (0, {"N": "21", "t_star": []}))
    line = _bad_input(capsys, [*_TSTAR, "--scheduler", loopback_scheduler], "--scheduler")
    assert "not a failure_time dict" in line


@pytest.fixture
def silent_port():
    """A loopback port that accepts TCP connections and never sends a byte."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    accepted = []

    def accept():
        while True:
            try:
                accepted.append(server.accept()[0])
            except OSError:
                return

    threading.Thread(target=accept, daemon=True).start()
    yield server.getsockname()[1]
    server.close()
    for conn in accepted:
        conn.close()


def test_a_port_that_never_speaks_dask_is_refused(silent_port):
    """Exit 2 and one line; the code before this fix waited in distributed's handshake for more
    than 200 s (the subprocess's limit below is a bound on a hang, not a timing)."""
    pytest.importorskip("distributed")
    done = subprocess.run([sys.executable, "-m", "icidr_pde.cli", *_TSTAR, "--scheduler",
                           f"tcp://127.0.0.1:{silent_port}"], capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert done.returncode == 2, done.stderr[-2000:]
    lines = [line for line in done.stderr.splitlines() if line.startswith("icidr-pde")]
    assert len(lines) == 1 and "--scheduler" in lines[0] and "no answer as a dask scheduler" in lines[0], done.stderr


# --- 10. dem: the number of disks is checked against the memory before LAMMPS allocates --------


def test_dem_refuses_a_cell_beyond_the_memory_before_allocating(no_processes, monkeypatch, tmp_path, capsys):
    from icidr_pde.dem import driver, runs

    def no_lammps(*args, **kwargs):
        raise AssertionError("LAMMPS was started")

    for module in (driver, runs):
        monkeypatch.setattr(module, "ShearCell", no_lammps)
    line = _bad_input(capsys, ["dem", "steady", "--particles", "1000000000", "--repeats", "1", "--jobs", "1",
                               "--no-progress", "--out", str(tmp_path)], "n_particles")
    assert "1000000000 is too large" in line and "TiB" in line
    assert list(tmp_path.iterdir()) == []


def test_dem_memory_estimate_grows_with_the_disks(monkeypatch):
    from icidr_pde.dem.params import DEMParams
    from icidr_pde.validation import MEMORY_ENV

    small, large = DEMParams(n_particles=1000), DEMParams(n_particles=100_000)
    assert large.memory_bytes() == pytest.approx(100 * small.memory_bytes())
    monkeypatch.setenv(MEMORY_ENV, str(int(2 * large.memory_bytes()) + 1))  # half of it is just enough
    DEMParams(n_particles=100_000)
    with pytest.raises(ValueError, match=r"`n_particles` = 100005 is too large"):
        DEMParams(n_particles=100_005)


# --- 5. an MP4 that ffmpeg could not finish is not written ------------------------------------


@pytest.fixture
def full_disk(tmp_path):
    """A 16 kB tmpfs: room for the JSON and an MP4's frames, not for its index (root only)."""
    folder = tmp_path / "full"
    folder.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16k", "tmpfs", str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.decode().strip()}")
    yield folder
    subprocess.run(["umount", str(folder)], check=False)


def test_an_mp4_on_a_full_disk_is_not_reported_written(full_disk, capfd):
    from icidr_pde.movies.sink import ffmpeg_exe

    if ffmpeg_exe() is None:
        pytest.skip("no ffmpeg")
    movie, summary = full_disk / "m.mp4", full_disk / "r.json"
    status = cli.main(["run", "--N", "21", "--t-end", "1", "--no-progress", "--movie", str(movie),
                       "--json", str(summary)])
    out, err = capfd.readouterr()
    assert status == 4, err
    assert "movie written" not in out
    assert f"could not write --movie {movie}: No space left on device" in err
    assert sorted(p.name for p in full_disk.iterdir()) == ["r.json"]  # no partial movie, no temporary file


def test_check_mp4_needs_the_index_and_the_whole_file(tmp_path):
    from icidr_pde.movies.render import write_movie
    from icidr_pde.movies.sink import check_mp4, ffmpeg_exe

    if ffmpeg_exe() is None:
        pytest.skip("no ffmpeg")
    import numpy as np

    z = np.linspace(0, 1, 11)
    path = tmp_path / "m.mp4"
    write_movie(path, z, [0.0, 1.0], np.zeros((2, 3, 11)) + 0.5)
    check_mp4(path)  # what ffmpeg finished passes
    data = path.read_bytes()
    moov = data.find(b"moov") - 4
    assert moov > 0
    for damaged in (data[:moov], data[:-1], data + b"\0\0\0"):
        path.write_bytes(damaged)
        with pytest.raises(OSError):
            check_mp4(path)


# --- 6. a full disk under NUMBA_CACHE_DIR costs a recompilation, not the run -------------------


def test_a_full_numba_cache_disk_is_one_line_not_a_traceback(full_disk):
    (full_disk / "filler").write_bytes(b"\0" * 12288)  # the rest of the 16 kB goes to the first files
    done = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "run", "--N", "21", "--t-end", "0.1",
                           "--no-progress", "--engine", "pde"], capture_output=True, text=True, timeout=900,
                          cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(full_disk)))
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and "reached t_end" in done.stdout
    notes = [line for line in done.stderr.splitlines() if "numba cache" in line]
    assert len(notes) == 1 and "No space left on device" in notes[0], done.stderr


# --- 11. a well-posed law's run fails only where the integrator says so, never as a false blow-up ---------


def test_small_2d_cell_runs_on_the_default():
    """A 24^2 cell of size 0.005 (fastest time scale 1.6e-14) failed at t = 9e-4 on the native
    engine's GMRES without a preconditioner; the default takes the preconditioned path and runs."""
    from icidr_pde import run

    res = run("icidr", "bump2d", (24, 24), 2.0, ["2"], H=0.005, L=0.005, ell=0.0005, series_times=[])
    assert res.reason == "reached t_end" and res.settings["engine"] != "native"


def test_2d_run_to_a_very_long_time_reaches_it():
    """8^2 to t = 1e15 ran 1.1 million steps and reported a blow-up at t = 6.6e7; iCIDR relaxes to
    steady shear, which the run must reach and keep (max|w| -> 0)."""
    from icidr_pde import run

    res = run("icidr", "bump2d", (8, 8), 1e15, ["1e15"], series_times=[])
    assert res.reason == "reached t_end" and res.n_steps < 5000
    assert abs(res.to_dict()["max_w"]["1e15"]) < 1e-8


@pytest.mark.parametrize("atol", ["1e-30", "1e-300"])
def test_atol_below_round_off_is_refused(atol, capsys):
    """--atol 1e-30 and 1e-300 ran and were reported as a blow-up at t* = 0 (an error test on
    round-off): refused before the run, one line naming the option and its range."""
    from icidr_pde import cli

    assert cli.main(["run", "--atol", atol, "--no-progress"]) == cli.EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "`--atol` must be in [" in err[0] and atol in err[0]
