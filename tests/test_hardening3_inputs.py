"""Regression tests of issue 42 ("Hardening, round 3"), items 4 and 12-19: inputs refused before
any work with one line naming the option, memory estimated before allocating, an interrupted
sweep keeping what finished, and a kernel cache cleared under a running compile.

Each test reproduces one defect through the command line (``icidr_pde.cli.main`` in process,
or ``python -m icidr_pde.cli`` as a subprocess where a signal or the exit status is the point)
or the public API.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from icidr_pde import cli
from icidr_pde.validation import MEMORY_ENV, ParameterError

ROOT = Path(__file__).resolve().parents[1]


def refused(capsys, *argv) -> str:
    """The one line with which the command line refuses `argv` (exit 2, no traceback)."""
    status = cli.main(list(argv))
    err = capsys.readouterr().err
    assert status == cli.EXIT_BAD_INPUT, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith(cli.PREFIX)]
    assert len(lines) == 1, err
    return lines[0]


# --- 12. the memory override ----------------------------------------------------------------


@pytest.mark.parametrize("value", ["inf", "1e400", "-1", "0", "nan", "lots"])
def test_memory_override_out_of_range_is_refused(value, monkeypatch, capsys):
    """$ICIDR_PDE_MEMORY=inf or 1e400 used to raise OverflowError (a traceback) in int(inf)."""
    monkeypatch.setenv(MEMORY_ENV, value)
    line = refused(capsys, "run", "--t-end", "0.1", "--no-progress")
    assert f"`${MEMORY_ENV}` must be a finite number of bytes > 0; got {value!r}" in line


# --- 15. t_end too small to have an output ------------------------------------------------


@pytest.mark.parametrize("t_end", ["1e-300", "5e-324", "1e-9"])
def test_t_end_below_the_time_resolution_is_refused(t_end, capsys):
    """--t-end 1e-300 used to raise IndexError after the run (no output time but t = 0); 5e-324
    said "Geometric sequence cannot include zero" without naming the option."""
    line = refused(capsys, "run", "--t-end", t_end, "--no-progress")
    assert "`--t-end` must be a finite number in [1e-08, 1e+15]" in line


def test_t_end_at_the_smallest_allowed_reaches_it(capsys):
    """The bound refuses no run that works: t_end = 1e-8 reaches t_end."""
    from icidr_pde import run

    result = run("icidr", "shear", 21, 1e-8)
    assert not result.blew_up and result.t_final == pytest.approx(1e-8)


# --- 16. an empty output path ---------------------------------------------------------------


@pytest.mark.parametrize("option", ["--json", "--plot", "--save"])
def test_empty_output_path_is_refused_before_the_run(option, tmp_path, monkeypatch, capsys):
    """`run --json ''` used to run and then fail to write (exit 4); `--plot ''` was called a directory."""
    monkeypatch.chdir(tmp_path)
    line = refused(capsys, "run", "--t-end", "0.1", "--no-progress", option, "")
    assert line.endswith(f"`{option}` must be a file path; got ''")
    assert "Geometric" not in line and list(tmp_path.iterdir()) == []


# --- 17. law files ----------------------------------------------------------------------------

LAW = ('yield_function = "M * p * (I / Psi)"\n'
       'dilatancy_function = "M * (I / (4 * Psi) + 1 - Psi / I)"\n')


def law_file(folder, text, name="law.toml") -> str:
    path = folder / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize("extra, said", [
    ('[material]\nfriction = [1]\n', "`friction` must be one of ['mu(I)', 'non-monotonic'] (or a FrictionLaw); got [1]"),
    ('x = ' + '[' * 2000 + ']' * 2000 + '\n', "is nested too deeply to be a law"),
], ids=["friction-list", "nested-2000"])
def test_law_file_contents_refused_in_one_line(extra, said, tmp_path, capsys):
    """friction = [1] was `TypeError: unhashable type` (a traceback); TOML nested 2000 deep a
    RecursionError."""
    line = refused(capsys, "law", "check", law_file(tmp_path, LAW + extra))
    assert said in line


def test_law_constant_beyond_a_double_is_refused(tmp_path, capsys):
    """1e308*1e308 is the exact 1e616 in sympy and an OverflowError traceback in the kernels."""
    text = LAW.replace('"M * p * (I / Psi)"', '"M * p * (I / Psi) + 1e308*1e308*p"')
    line = refused(capsys, "law", "check", law_file(tmp_path, text))
    assert "yield_function" in line and "outside the range of a double" in line


def test_law_flat_sum_of_many_terms_is_a_law(tmp_path):
    """A flat 3400-term sum (a left-nested tree 3400 deep in Python's ast) was refused as
    "nested too deeply", and one of 900 terms overflowed the builder's recursion. Its value is the
    law's: n/2 terms +I and n/2 terms -k sum to n/2 (I - k)."""
    import sympy as sp

    from icidr_pde.rheology.declarative import parse_expression

    I, k = sp.symbols("I k")
    for n in (900, 3400):
        text = "I" + "".join("+I" if i % 2 else "-k" for i in range(n))
        assert sp.expand(parse_expression(text, {"I": I, "k": k}) - (I + n // 2 * (I - k))) == 0
    assert sp.expand(parse_expression("I - (k - I) + -k**2 - -I", {"I": I, "k": k}) - (3 * I - k - k**2)) == 0


@pytest.mark.parametrize("kind", ["directory", "fifo", "device"])
@pytest.mark.parametrize("suffix", [".toml", ".py"])
def test_law_file_that_is_not_a_regular_file(kind, suffix, tmp_path, capsys):
    """A directory, FIFO or device named x.toml was reported as "does not exist"."""
    path = tmp_path / f"x{suffix}"
    if kind == "directory":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/null")
    line = refused(capsys, "law", "check", str(path))
    what = {"directory": "a directory", "fifo": "a FIFO", "device": "a device"}[kind]
    assert line.endswith(f"`rheology` must be a regular file; {str(path)!r} is {what}")


def test_unreadable_law_file(tmp_path, monkeypatch, capsys):
    """An unreadable law file was a PermissionError traceback (simulated: the tests may run as root)."""
    import pathlib

    path = law_file(tmp_path, LAW)

    def denied(self, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(pathlib.Path, "read_text", denied)
    line = refused(capsys, "law", "check", path)
    assert line.endswith(f"law file {path!r} cannot be read: Permission denied")


# --- 19. figures --movies, dem --cache, tstar --load ------------------------------------------


def test_unknown_movie_refused_before_any_figure(tmp_path, monkeypatch, capsys):
    """`figures --movies movie99` computed fig 3 first and then raised KeyError."""
    from icidr_pde.cli import figures as figures_cli

    def no_figures(*args, **kwargs):
        raise AssertionError("a figure was computed before the movies were checked")

    monkeypatch.setattr(figures_cli, "make_figures", no_figures)
    out = tmp_path / "gallery"
    line = refused(capsys, "figures", "--only", "fig3", "--movies", "movie1", "movie99", "--out", str(out))
    assert "`--movies` must name movies of" in line and "got ['movie99']" in line
    assert not out.exists()


def test_dem_cache_that_is_a_file_refused_before_the_runs(tmp_path, monkeypatch, capsys):
    """`dem steady --cache FILE` ran LAMMPS for 21 s, then raised FileExistsError."""
    from icidr_pde.dem import steady

    def no_runs(*args, **kwargs):
        raise AssertionError("the DEM runs started before --cache was checked")

    monkeypatch.setattr(steady, "run_steady_study", no_runs)
    cache = tmp_path / "cache"
    cache.write_text("not a folder")
    line = refused(capsys, "dem", "steady", "--cache", str(cache), "--out", str(tmp_path), "--repeats", "1",
                   "--no-progress")
    assert line.endswith(f"`--cache` must be a directory; got the file {str(cache)!r}")
    assert cache.read_text() == "not a folder"


@pytest.mark.parametrize("curve", ['{"21": "x"}', '{"21": [1]}', '{"fd": {"x": 1}}', '{"21": -1}', '{"0": 1}'])
def test_tstar_load_of_wrong_values_refused(curve, tmp_path, capsys):
    """`tstar --load x=l.json` with non-numeric values raised TypeError in the plot."""
    saved = tmp_path / "l.json"
    saved.write_text(curve)
    plot = tmp_path / "p.png"
    line = refused(capsys, "tstar", "--load", f"x={saved}", "--plot", str(plot))
    assert "must map each N (an integer >= 1) to t* (a finite number >= 0, or null: no failure)" in line
    assert not plot.exists()


def test_tstar_load_of_a_saved_sweep_is_plotted(tmp_path, capsys):
    """The check refuses no sweep that `tstar --json` writes."""
    saved = tmp_path / "l.json"
    saved.write_text(json.dumps({"21": None, "23": 0.5, "25": 0.01}))
    plot = tmp_path / "p.png"
    assert cli.main(["tstar", "--load", f"x={saved}", "--plot", str(plot)]) == 0
    assert plot.stat().st_size > 0


# --- 18. `cache clear` while another run compiles ---------------------------------------------


@pytest.fixture
def own_kernel_cache(tmp_path, monkeypatch):
    """A kernel folder of this test alone (the process's usual folder again afterwards)."""
    from icidr_pde import kernel_cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    kernel_cache._reset()
    yield kernel_cache
    monkeypatch.undo()
    kernel_cache._reset()


def test_cache_clear_right_after_a_kernel_is_written(own_kernel_cache, tmp_path, monkeypatch):
    """`icidr-pde cache clear` in another process between the writing of a new law's kernel module
    and its import crashed the run: `RuntimeError: cannot cache function '_rsqrt0'` (numba found
    no source file to key its cache on)."""
    from icidr_pde.rheology import codegen

    kernel_cache = own_kernel_cache
    store = kernel_cache.store

    def store_then_clear(kernel, ext, data):
        path = store(kernel, ext, data)
        assert kernel_cache.clear()[1] >= 1 and not path.exists()  # the other process's clear
        return path

    monkeypatch.setattr(kernel_cache, "store", store_then_clear)
    source = "from numba import njit\n\n\n@njit(cache=True)\ndef _rsqrt0(x):\n    return 1.0 / x ** 0.5\n"
    module = codegen._load("test_clear", f"a law of {tmp_path}", lambda: source)
    assert module._rsqrt0(4.0) == 0.5  # compiled, and its compiled code saved to the cache


def test_cache_clear_leaves_writes_in_progress(own_kernel_cache):
    """A clear removed the temporary files other processes were writing (the kernel cache's and
    numba's), failing their writes; they are left, and the finished files go."""
    kernel_cache = own_kernel_cache
    kept = kernel_cache.store(kernel_cache.stem("test", "k"), ".py", b"x = 1\n")
    folder = kernel_cache.folder()
    numba_writing = folder / "__pycache__" / f"{kernel_cache.stem('test', 'k')}.nbi.tmp.0123456789abcdef"
    numba_writing.write_bytes(b"half")
    with kernel_cache.scratch(".so.tmp") as writing:
        path, count, _ = kernel_cache.clear()
        assert path == folder and count == 1 and not kept.exists()
        assert writing.exists() and numba_writing.exists()


def test_native_library_removed_by_a_clear_before_it_is_loaded(own_kernel_cache, tmp_path, monkeypatch):
    """A clear between the compiling of a native library and its loading made the run fall back
    to the py-pde path ("native library not loadable"); the library is compiled again."""
    import _ctypes

    from icidr_pde.native import NativeUnavailable, build

    kernel_cache = own_kernel_cache
    try:
        build.sundials(), build._compiler()
    except NativeUnavailable as err:
        pytest.skip(f"no native engine here: {err}")
    library_bytes = Path(_ctypes.__file__).read_bytes()  # a loadable shared library, not compiled here
    compiled = []

    def compile_then_cleared(rheology, kinematics, index, cc, libdir, libs, name):
        compiled.append(name)
        path = kernel_cache.store(name, ".so", library_bytes)
        if len(compiled) == 1:
            kernel_cache.clear()  # another process's `icidr-pde cache clear`
        return path

    monkeypatch.setattr(build, "_key", lambda *args: f"a law of {tmp_path}")
    monkeypatch.setattr(build, "_compile", compile_then_cleared)
    monkeypatch.setattr(build, "_declare", lambda lib, kinematics: None)
    assert build.library(None, None) is not None
    assert len(compiled) == 2


# --- 14. Ctrl-C during tstar ------------------------------------------------------------------


def test_ctrl_c_during_a_tstar_sweep_keeps_what_finished(tmp_path):
    """Ctrl-C during `tstar --jobs 2` was a 30-line traceback, the pool ran on for 9-18 s and
    --json was not written. Now: the finished cases in --json, exit 130, the workers stopped at
    once (the N = 400 case still running is not waited for), no traceback."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    cache, out = tmp_path / "cases", tmp_path / "tstar.json"
    proc = subprocess.Popen([sys.executable, "-m", "icidr_pde.cli", "tstar", "--rheology", "icidr",
                             "--discretization", "fd", "--N", "8,10,400", "--t-end", "20", "--jobs", "2",
                             "--accuracy", "paper",  # scipy's BDF: N = 400 runs long enough to be stopped
                             "--cache", str(cache), "--json", str(out), "--no-progress"],
                            cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 600  # a hang guard, not a measurement
        while not (cache.is_dir() and any(n.endswith(".json") for n in os.listdir(cache))):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no case finished"
            time.sleep(0.1)
        workers = [pid for pid in subprocess.run(["pgrep", "-P", str(proc.pid)], capture_output=True,
                                                 text=True).stdout.split()
                   if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()]
        assert workers
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "interrupted after" in stderr
    finished = {json.loads(p.read_text())["case"]["N"] for p in cache.glob("*.json")}
    written = json.loads(out.read_text())["discretizations"]["fd"]["t_star"]
    assert set(written) == {str(n) for n in finished} and "400" not in written  # the N = 400 run was stopped
    assert all(t is None for t in written.values())  # iCIDR does not fail
    for pid in workers:  # stopped with the sweep, not left to finish their cases
        assert not Path(f"/proc/{pid}").exists() or b"spawn_main" not in Path(f"/proc/{pid}/cmdline").read_bytes()


def test_interrupted_case_of_a_serial_sweep_is_not_a_case_without_failure(tmp_path, monkeypatch, capsys):
    """In this process (--jobs 1) the run swallowed Ctrl-C and returned 'interrupted at t = ...':
    the sweep recorded that case as t* = null (no failure) in --json and in --cache, and went on."""
    import importlib

    from icidr_pde.engines.scipy import ScipyEngine

    failure_time = importlib.import_module("icidr_pde.studies.failure_time")  # the module, not its function
    original_run, original_value_at = failure_time.run, ScipyEngine.value_at
    calls = []

    def interrupting(self, t):
        if t > 0.5:
            raise KeyboardInterrupt
        return original_value_at(self, t)

    def run_interrupting_the_second(*args, **kwargs):
        calls.append(args)
        if len(calls) == 2:  # Ctrl-C during the second case
            monkeypatch.setattr(ScipyEngine, "value_at", interrupting)
        return original_run(*args, **kwargs)

    monkeypatch.setattr(failure_time, "run", run_interrupting_the_second)
    cache, out = tmp_path / "cases", tmp_path / "tstar.json"
    status = cli.main(["tstar", "--rheology", "icidr", "--discretization", "fd", "--N", "8,12", "--t-end", "2",
                       "--accuracy", "paper", "--jobs", "1", "--cache", str(cache), "--json", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 130, err
    written = json.loads(out.read_text())["discretizations"]["fd"]["t_star"]
    assert len(calls) == 2 and written == {"12": None}  # the first case (large N first)
    assert [json.loads(p.read_text())["case"]["N"] for p in cache.glob("*.json")] == [12]


# --- 13. the memory check before any allocation -----------------------------------------------


def test_memory_refusal_comes_before_the_state_is_allocated(monkeypatch):
    """A 2048^2 refusal came after a 502 MB peak: the state (and the initial condition's arrays)
    was built before the memory check of the run's linear algebra. Scaled down to 512^2: the
    memory available is set so that the least a 2-D run needs fits and the default path's
    preconditioner does not; the refusal allocates less than one array of the state's size."""
    import tracemalloc

    from icidr_pde import run
    from icidr_pde.discretizations.grid_size import PLANE2D

    n = 512
    least, _ = PLANE2D.least(n * n)
    monkeypatch.setenv(MEMORY_ENV, f"{2.1 * least:.0f}")
    with pytest.raises(ParameterError, match=r"`Nx` x `Nz` = 512 x 512 with method 'CVODE'"):
        run("icidr", "bump2d", (n, n), 1e-3)  # kernels compiled and modules imported: not counted below
    tracemalloc.start()
    try:
        with pytest.raises(ParameterError, match=r"`Nx` x `Nz` = 512 x 512 with method 'CVODE'"):
            run("icidr", "bump2d", (n, n), 1e-3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    state_bytes = 3 * n * n * 8  # phi, u, w in doubles
    assert peak < state_bytes, f"{peak} bytes allocated before the refusal"


# --- 4. the thin cell's line preconditioner in the memory model -------------------------------


def thin_case(nx=256, nz=32, H=30.0):
    """iCIDR bump2d on a thin cell, hx = 60 hz (as 4096 x 256 at L = 120000)."""
    from icidr_pde.case import build_case

    return build_case("icidr", "bump2d", "fv2d", (nx, nz), scene_params={"H": H, "L": 60 * H * nx / nz})


def test_line_preconditioner_memory_is_covered_by_the_estimate():
    """What the line preconditioner's set-up allocates (tracemalloc: the analytic Jacobian, its
    line part, I - gamma J_line) and holds (SuperLU's factors, C memory counted from their
    entries; the line pattern) is within the estimate that the memory check adds for it."""
    import tracemalloc

    from icidr_pde.engines.linear.line import LineGmres, line_preconditioner
    from icidr_pde.engines.stiff import conserved

    case = thin_case()
    pde, state = case.pde, case.state
    pattern = pde.line_pattern(state)
    assert pattern is not None
    jac = pde.make_jacobian(state)
    weights, anchor = conserved(pde, state, None)
    y = state.data.ravel().copy()
    jac(0.0, y)
    tracemalloc.start()
    try:
        precond = line_preconditioner(jac, pattern, weights, anchor)
        precond.setupfn(0.0, y, None, False, np.zeros(1, dtype=np.int32), 0.01)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    saved = next(c.cell_contents for c in precond.setupfn.__closure__ if isinstance(c.cell_contents, dict))
    factors = 12 * (saved["lu"].L.nnz + saved["lu"].U.nnz)  # a double and a 32-bit index an entry
    held = pattern.data.nbytes + pattern.indices.nbytes + pattern.indptr.nbytes
    memory = LineGmres().memory(y.size, "CVODE", "krylov", thin=True)
    estimate, note = memory.bytes, memory.note
    assert "line preconditioner" in note
    assert peak + factors + held <= estimate


def test_thin_cell_run_counts_its_line_preconditioner(monkeypatch):
    """A thin 2-D cell was accepted on the estimate of GMRES alone (2.44 GiB for 4096 x 256) and
    peaked at twice it: its line preconditioner was not in the memory model. Scaled down to
    256 x 32: with memory for the scheme's estimate and half of the preconditioner's, the run is
    refused before it starts, naming the preconditioner."""
    from icidr_pde import run
    from icidr_pde.discretizations.grid_size import PLANE2D
    from icidr_pde.engines.linear.line import LineGmres

    nx, nz, H = 256, 32, 30.0
    scheme, _ = PLANE2D.estimate(nx * nz)
    line = LineGmres().memory(3 * nx * nz, "CVODE", "krylov", thin=True).bytes
    monkeypatch.setenv(MEMORY_ENV, f"{2 * (scheme + line / 2):.0f}")
    with pytest.raises(ParameterError, match=r"`Nx` x `Nz` = 256 x 32 with method 'CVODE', Jacobian 'krylov' "
                                             r"\(GMRES with the line preconditioner\) needs about"):
        run("icidr", "bump2d", (nx, nz), 1e-6, H=H, L=60 * H * nx / nz)
    monkeypatch.setenv(MEMORY_ENV, f"{2.2 * (scheme + line):.0f}")  # enough: the run goes
    assert run("icidr", "bump2d", (nx, nz), 1e-6, H=H, L=60 * H * nx / nz).t_final == pytest.approx(1e-6)


@pytest.mark.parametrize("suffix", [".toml", ".py"])
def test_law_file_that_cannot_be_opened(suffix, tmp_path, monkeypatch, capsys):
    """A Python law file that cannot be read was reported as a file that was run and raised
    PermissionError (simulated: the tests may run as root, who reads every file)."""
    import builtins

    path = law_file(tmp_path, LAW, f"law{suffix}")
    original = builtins.open

    def denied(file, *args, **kwargs):
        if os.fspath(file) == path:
            raise PermissionError(13, "Permission denied", path)
        return original(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", denied)
    line = refused(capsys, "law", "check", path)
    assert line.endswith(f"`rheology` must be a readable file; {path!r} cannot be read (Permission denied)")
