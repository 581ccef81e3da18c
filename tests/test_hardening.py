"""Regression tests of issue 15: no silent wrong answers, no lost data, clear errors.

Every test reproduces one defect through the public API (``icidr_pde.run``, the PDE
classes, ``Rheology.stress``) or the command line (``icidr_pde.cli.main`` in process, or
``python -m icidr_pde.cli`` as a subprocess where a signal or the exit status is the point).
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from icidr_pde import ShearCellPDE, run
from icidr_pde import cli
from icidr_pde.cells.shear1d.cheb import ChebyshevShearCellPDE, cgl_nodes
from icidr_pde.rheology import ICIDR, Material, MuIPhiI
from icidr_pde.scenes import get_scene

ROOT = Path(__file__).resolve().parents[1]
METHODS = ("BDF", "Radau", "LSODA", "CVODE")


def cli_process(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.Popen([sys.executable, "-m", "icidr_pde.cli", *args], cwd=cwd, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def wait_for_progress(proc, timeout=900, settle=1.0):
    """Block until the integration is under way: the bar shows a time short of its end, or it
    has said "integrating" for `settle` seconds (a bar moves only at its tracker's times, and a
    run past its slow start may reach t_end between two of them)."""
    fd = proc.stderr.fileno()
    os.set_blocking(fd, False)
    seen, start, integrating_since = "", time.monotonic(), None
    while time.monotonic() - start < timeout:
        try:
            seen += os.read(fd, 65536).decode(errors="replace")
        except BlockingIOError:
            pass
        now = time.monotonic()
        if integrating_since is None and "integrating" in seen:
            integrating_since = now
        moved = any(0 < float(t) < float(total)
                    for t, total in re.findall(r"([0-9.]+(?:e[+-]?\d+)?)/([0-9.]+(?:e[+-]?\d+)?) \[", seen))
        if moved or (integrating_since is not None and now - integrating_since > settle):
            return seen  # the integration is under way (not only compiling, not done)
        if proc.poll() is not None:
            raise AssertionError(f"process ended early: {seen}")
        time.sleep(0.2)
    raise AssertionError("the run never started")


# --- 1. interrupts ----------------------------------------------------------------------


def test_interrupted_run_is_reported_as_interrupted(monkeypatch):
    """A KeyboardInterrupt during the run (py-pde's Controller swallows it) must not be
    reported as 'reached t_end': the result keeps what was computed up to the time reached."""
    from icidr_pde.engines.scipy import ScipyEngine

    original = ScipyEngine.value_at  # the state at each output time of the run path

    def interrupting(self, t):
        if t > 0.5:
            raise KeyboardInterrupt
        return original(self, t)

    monkeypatch.setattr(ScipyEngine, "value_at", interrupting)
    res = run("icidr", "shear", 21, 10.0, ["0", "0.25", "5", "10"], method="BDF")
    assert res.reason.startswith("interrupted")
    assert not res.blew_up
    # the last output reached (dense: every 10/399), then the step the engine had reached past it
    assert 0.45 < res.max_w_t[-1] <= 0.5 < res.t_final < 10.0
    assert res.time_labels == ["0", "0.25"]
    assert np.isfinite(np.array(res.final)).all()
    assert res.to_dict()["t_final"] == res.t_final


@pytest.mark.parametrize("sig, status", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_cli_signal_keeps_results_and_exits_non_zero(tmp_path, sig, status):
    proc = cli_process("run", "--scene", "sine", "--t-end", "1e5", "--method", "BDF", "--rtol", "1e-10",
                       "--N", "1001", "--json", "i.json", "--save", "s.h5", cwd=tmp_path)
    try:
        wait_for_progress(proc)
        proc.send_signal(sig)
        proc.wait(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == status
    summary = json.loads((tmp_path / "i.json").read_text())
    assert summary["reason"].startswith("interrupted")
    assert 0 < summary["t_final"] < 1e5 and not summary["blew_up"]
    with h5py.File(tmp_path / "s.h5") as fh:  # a valid file holding the frames written
        assert fh["data"].shape[0] >= 1


# --- 2. minimum step relative to the problem's time scale ----------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", [dict(phi0=0.816999, t_end=1.0), dict(N=47, H=0.01, t_end=1.0)],
                         ids=["near-jamming", "tiny-cell"])
def test_icidr_runs_near_jamming_and_in_tiny_cells(method, case):
    """iCIDR is well-posed: these runs must not 'blow up at t* = 0' on any method
    (CVODE's absolute minimum step 1e-14 stopped them)."""
    case = dict(case)
    N = case.pop("N", 21)
    res = run("icidr", "shear", N, case.pop("t_end"), [0, 1.0], method=method, **case)
    assert not res.blew_up, res.reason
    assert res.t_final == 1.0


# --- 3. output paths -----------------------------------------------------------------------


@pytest.mark.parametrize("option", ["--json", "--save", "--plot"])
def test_unwritable_output_is_refused_before_running(tmp_path, capsys, option):
    (tmp_path / "out").mkdir()
    for target in (tmp_path / "out", tmp_path / "missing" / "x.out"):
        status = cli.main(["run", "--N", "9", "--t-end", "0.1", "--no-progress", option, str(target)])
        captured = capsys.readouterr()
        assert status == 2
        assert option in captured.err and str(target) in captured.err
        assert "Result(" not in captured.out  # nothing was run
        assert "Traceback" not in captured.err


def test_write_failure_after_the_run_is_reported_and_the_rest_written(tmp_path, capsys, monkeypatch):
    from icidr_pde.result import Result

    def broken(self, path):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(Result, "save_json", broken)
    plot, save = tmp_path / "p.png", tmp_path / "s.h5"
    status = cli.main(["run", "--N", "9", "--t-end", "0.1", "--no-progress", "--json", str(tmp_path / "r.json"),
                       "--plot", str(plot), "--save", str(save)])
    captured = capsys.readouterr()
    assert status == 4
    assert "r.json" in captured.err and "No space left" in captured.err
    assert plot.exists() and save.exists()
    assert "Traceback" not in captured.err


def test_plot_path_printed_is_the_file_written(tmp_path, capsys):
    target = tmp_path / "figure"  # no suffix: matplotlib appends .png
    assert cli.main(["run", "--N", "9", "--t-end", "0.1", "--no-progress", "--plot", str(target)]) == 0
    out = capsys.readouterr().out
    written = [line.split("plot written to ", 1)[1].strip() for line in out.splitlines()
               if "plot written to" in line]
    assert written and Path(written[0]).is_file()


# --- 4. Chebyshev snapshot coordinates -------------------------------------------------------


@pytest.mark.parametrize("discretization, N", [("cheb", 9), ("fd", 8)])
def test_saved_snapshots_carry_the_true_nodes(tmp_path, discretization, N):
    from icidr_pde.snapshots import read_snapshots

    path = tmp_path / "s.h5"
    res = run("icidr", "shear", N, 0.2, [0, 0.1, 0.2], discretization=discretization, save=str(path))
    snap = read_snapshots(path)
    expected = cgl_nodes(N, 30.0) if discretization == "cheb" else (np.arange(N) + 0.5) * 30.0 / N
    np.testing.assert_allclose(snap["z"], expected, rtol=1e-15)
    np.testing.assert_allclose(snap["times"], [0, 0.1, 0.2])
    np.testing.assert_allclose(snap["w"], res.w)
    np.testing.assert_allclose(snap["phi"], res.phi)


# --- 5. snapshot files and faults -------------------------------------------------------------


@pytest.mark.parametrize("bad", [dict(jacobian="dense"), dict(method="RK45"), dict(rtol=2.0),
                                 dict(N=3), dict(times=[0, 99])])
def test_invalid_option_leaves_an_existing_file_untouched(tmp_path, bad):
    path = tmp_path / "s.h5"
    run("icidr", "shear", 9, 0.2, [0, 0.1, 0.2], save=str(path))
    before = path.read_bytes()
    args = dict(rheology="icidr", scene="shear", N=9, t_end=0.2, times=[0, 0.2], save=str(path))
    args.update(bad)
    with pytest.raises(ValueError):
        run(**args)
    assert path.read_bytes() == before


def test_failed_run_still_writes_a_complete_snapshot_file(tmp_path):
    path = tmp_path / "s.h5"
    res = run("mui", "shear", 201, 1.0, ["0", "0.005", "0.5"], save=str(path))
    assert res.blew_up
    with h5py.File(path) as fh:
        np.testing.assert_allclose(fh["times"][:], [0, 0.005])


# --- 6. mass conservation on every path -------------------------------------------------------

PATHS = [("BDF", "analytic"), ("BDF", "sparse-fd"), ("BDF", "none"), ("Radau", "analytic"),
         ("Radau", "sparse-fd"), ("LSODA", "banded-fd"), ("LSODA", "analytic"), ("LSODA", "none"),
         ("CVODE", "banded-fd"), ("CVODE", "analytic"), ("CVODE", "none")]


@pytest.mark.parametrize("method, jacobian", PATHS)
@pytest.mark.parametrize("eps", [0.05, 5.0])
def test_mass_conserved_to_round_off_on_every_path(method, jacobian, eps):
    """The finite-volume fluxes telescope and vanish at the walls, so the integral of phi
    is conserved to round-off whatever the integrator, if its Newton updates conserve it."""
    res = run("icidr", "shear", 7, 10.0, [0, 10], method=method, jacobian=jacobian, eps=eps)
    assert not res.blew_up
    assert abs(res.mass_drift) < 2e-15, res.mass_drift


@pytest.mark.parametrize("method, jacobian", [("Radau", "sparse-fd"), ("BDF", "sparse-fd"), ("CVODE", "banded-fd")])
def test_mass_conserved_to_round_off_scene_sine(method, jacobian):
    """scipy's own colored differences drifted the mass by 6e-11 here (Radau)."""
    res = run("icidr", "sine", 47, 20.0, [0, 20], method=method, jacobian=jacobian)
    assert not res.blew_up
    assert abs(res.mass_drift) < 2e-15, res.mass_drift


@pytest.mark.parametrize("method, jacobian", [("BDF", "analytic"), ("BDF", "none"), ("CVODE", "analytic"),
                                              ("CVODE", "none")])
def test_chebyshev_mass_conserved_to_round_off(method, jacobian):
    res = run("icidr", "shear", 9, 2.0, [0, 2], discretization="cheb", method=method, jacobian=jacobian)
    assert not res.blew_up
    assert abs(res.mass_drift) < 1e-14, res.mass_drift


# --- 7. grid size bounds ------------------------------------------------------------------------


@pytest.mark.parametrize("discretization", ["fd", "cheb"])
def test_grid_beyond_the_discretization_maximum_is_refused(discretization, capsys):
    with pytest.raises(ValueError, match="`N`") as info:
        run("icidr", "shear", 1_000_000, 1.0, discretization=discretization)
    message = str(info.value)
    assert "1000000" in message and "maximum" in message and "memory" in message
    status = cli.main(["run", "--N", "1000000", "--discretization", discretization, "--no-progress"])
    assert status == 2 and "1000000" in capsys.readouterr().err


# --- 8. errors naming the parameter -------------------------------------------------------------


@pytest.mark.parametrize("kwargs, expected", [
    (dict(phi0="0.5"), "`phi0`.*'0.5'"), (dict(t_end="10"), "`t_end`.*'10'"), (dict(t_end=None), "`t_end`.*None"),
    (dict(rtol="1e-6"), "`rtol`.*'1e-6'"), (dict(N=float("nan")), "`N`.*nan"), (dict(N="21"), "`N`.*'21'"),
    (dict(t_end=float("inf")), "`t_end`.*finite.*inf"), (dict(H=float("inf")), "`H`.*finite.*inf"),
    (dict(atol=float("inf")), "`atol`.*finite.*inf"), (dict(N=True), "`N`.*True"),
    (dict(times=["abc"]), "`times`.*'abc'"), (dict(eps=[1, 2]), "`eps`"),
    (dict(rheology="ICIDR"), "`rheology`.*'ICIDR'"), (dict(accuracy="best"), "`accuracy`.*'best'"),
])
def test_api_errors_name_parameter_range_and_value(kwargs, expected):
    args = dict(rheology="icidr", scene="shear", N=21, t_end=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=expected):
        run(**args)


@pytest.mark.parametrize("argv, name", [
    (["--times", "abc"], "--times"), (["--t-end", "inf"], "--t-end"), (["--N", "nan"], "--N"),
    (["--rtol", "x"], "--rtol"), (["--H", "-1"], "--H"), (["--phi0", "0.9"], "--phi0"),
])
def test_cli_errors_name_the_option(capsys, argv, name):
    with pytest.raises(SystemExit) as info:
        status = cli.main(["run", "--no-progress", *argv])
        raise SystemExit(status)
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert name in err and "Traceback" not in err
    assert err.strip().splitlines()[-1].startswith("icidr-pde: error:")


def test_material_accepts_numpy_numbers():
    m = Material(mu_s=np.float32(0.25), I0=np.int64(1))
    assert m.I0 == 1.0 and m.params[2] == 1.0


@pytest.mark.parametrize("cls", [ShearCellPDE, ChebyshevShearCellPDE])
@pytest.mark.parametrize("N, H, expected", [("21", 30.0, "`N`.*'21'"), (21, "30", "`H`.*'30'"),
                                            (float("nan"), 30.0, "`N`.*nan"), (21, float("inf"), "`H`.*inf")])
def test_pde_classes_validate_like_run(cls, N, H, expected):
    with pytest.raises(ValueError, match=expected):
        cls("icidr").make_grid(N, H)


# --- 9. kernels at absurd magnitudes -------------------------------------------------------------


@pytest.mark.parametrize("rheology", [ICIDR(), MuIPhiI()])
@pytest.mark.parametrize("uz, wz", [(0.0, 1e155), (1e155, 0.0), (1e200, -1e200), (1e-163, 0.0), (0.0, -1e-170)])
def test_kernels_never_return_nan_silently(rheology, uz, wz):
    """Either the stress is computed without spurious overflow/underflow (degree-2
    homogeneous: p(lambda S) = lambda^2 p(S)), or the input is refused by name."""
    try:
        p, txz, tzz = (float(x) for x in rheology.stress(0.78, uz, wz))
    except ValueError as err:
        assert "strain rate" in str(err) and "float range" in str(err)
        return
    assert np.isfinite([p, txz, tzz]).all() and p > 0
    scale = max(abs(uz), abs(wz))
    unit = [float(x) for x in rheology.stress(0.78, uz / scale, wz / scale)]
    np.testing.assert_allclose([p, txz, tzz], np.array(unit) * scale**2, rtol=1e-13)


# --- 10. exit status, messages and metadata ----------------------------------------------------


def test_exit_status_of_run(capsys, tmp_path):
    assert cli.main(["run", "--N", "9", "--t-end", "0.1", "--no-progress"]) == 0
    assert cli.main(["run", "--rheology", "mui", "--N", "201", "--t-end", "1", "--method", "BDF",
                     "--no-progress", "--json", str(tmp_path / "f.json")]) == 3
    assert json.loads((tmp_path / "f.json").read_text())["blew_up"]
    assert cli.main(["run", "--N", "9", "--rtol", "-1", "--no-progress"]) == 2


def test_sundials_messages_go_into_the_result_not_the_terminal(capfd):
    res = run("mui", "shear", 201, 1.0, [0], method="CVODE")
    out, err = capfd.readouterr()
    assert res.blew_up
    assert "cvHandleFailure" not in out + err
    assert "cvHandleFailure" in res.reason or "error test failed" in res.reason


@pytest.mark.parametrize("argv", [[], ["--discretization", "cheb"], ["--method", "LSODA"],
                                  ["--method", "BDF", "--jacobian", "sparse-fd"], ["--accuracy", "draft"],
                                  ["--method", "CVODE", "--jacobian", "none"]])
def test_json_metadata_is_what_ran(tmp_path, argv):
    path = tmp_path / "r.json"
    assert cli.main(["run", "--N", "9", "--t-end", "0.1", "--no-progress", "--json", str(path), *argv]) == 0
    data = json.loads(path.read_text())
    res = run("icidr", "shear", 9, 0.1, **{k.lstrip("-"): v for k, v in zip(argv[::2], argv[1::2])})
    for key in ("discretization", "method", "jacobian", "rtol", "atol", "N"):
        assert data[key] == getattr(res, key), key


def test_sparse_fd_on_a_dense_discretization_is_refused():
    """It used to run dense differences labelled 'sparse-fd' in the JSON."""
    with pytest.raises(ValueError, match="sparse-fd"):
        run("icidr", "shear", 9, 0.1, discretization="cheb", method="BDF", jacobian="sparse-fd")


# --- 11. py-pde's solve() on our PDE classes ----------------------------------------------------


@pytest.mark.parametrize("cls", [ShearCellPDE, ChebyshevShearCellPDE])
def test_solve_defaults_to_the_stiff_solver(cls):
    eq = cls("icidr")
    grid = eq.make_grid(21, 30.0)
    state = eq.make_state(grid, *get_scene("shear").initial_condition(eq.nodes(grid)))
    final, info = eq.solve(state, t_range=0.5, tracker=None, ret_info=True)
    assert info["solver"]["class"] == "StiffSolver"
    assert np.isfinite(final.data).all()


# --- 12. help texts --------------------------------------------------------------------------


def _subparsers(parser, prefix=()):
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield prefix + (name,), sub
                yield from _subparsers(sub, prefix + (name,))


def test_every_help_has_a_description_and_shows_defaults():
    parser = cli.make_parser()
    for path, sub in _subparsers(parser):
        if path[0] == "dem":  # the DEM command line is reworked on its own branch (issue 15 item 13)
            continue
        text = sub.format_help()
        assert sub.description, path
        assert "lead" not in text.lower() and "wiring" not in text.lower(), path
        for action in sub._actions:
            if action.option_strings and action.default not in (None, False, "==SUPPRESS==") \
                    and action.dest != "help":
                assert action.help and "default" in sub._get_formatter()._expand_help(action), \
                    (path, action.dest)


def test_rheology_default_is_shown():
    parser = cli.make_parser()
    text = dict(_subparsers(parser))[("run",)].format_help()
    assert "default: icidr" in text


def test_help_names_the_2d_cell_and_every_scene():
    """2-D scenes run (scenes2d.py): the top-level and `run` help must not say the cell is 1-D only,
    and --scene's help names every registered scene with its dimension."""
    import re

    from icidr_pde.scenes import SCENES

    parser = cli.make_parser()
    run_help = dict(_subparsers(parser))[("run",)]
    for text in (parser.format_help(), run_help.format_help()):
        flat = " ".join(text.split())
        assert "1-D shear cell" not in flat and "2-D" in flat
    scene_help = " ".join(next(a.help for a in run_help._actions if a.dest == "scene").split())
    for dim in (1, 2):
        listed = re.search(f"{dim}-D: ([a-z0-9, ]+)", scene_help).group(1).strip().split(", ")
        assert sorted(listed) == sorted(n for n, c in SCENES.items() if getattr(c, "dim", 1) == dim)


@pytest.mark.parametrize("engine", ["native", "pde"])
def test_one_bad_phi0_is_reported_as_one_value(capsys, engine):
    """A scalar --phi0 outside (0, phi_c) is echoed as the number given, not as a range."""
    status = cli.main(["run", "--phi0", "0.9", "--N", "9", "--t-end", "0.1", "--no-progress", "--engine", engine])
    err = capsys.readouterr().err
    assert status == 2
    assert err.rstrip().endswith("`--phi0` must lie in (0, phi_c) = (0, 0.817); got 0.9"), err


def test_a_bad_phi_profile_is_reported_by_its_range():
    from icidr_pde.rheology import get_rheology

    with pytest.raises(ValueError, match=r"got values in \[0.5, 0.9\]$"):
        get_rheology("icidr").material.check_phi(np.array([0.5, 0.9]), "phi")
