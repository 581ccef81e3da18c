"""The native engine (icidr_pde.native): C kernels and CVODE without Python in the loop.

Against independent truth: py-pde's grid and boundary setters; a fourth-order difference
of the native right-hand side for its Jacobian (the C is printed from the numba template:
tests/test_translate.py); the converged references of data/reference to the accuracy the
README states for CVODE at N = 201; mass conservation; the failure of mu(I),Phi(I) (t* of
the py-pde path's CVODE, the same integrator); the imports of a warm run in a fresh process.
No timings.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from icidr_pde import catalog
from icidr_pde.cells.shear1d.native import FdProblem
from icidr_pde.native import NativeUnavailable
from icidr_pde.native_case import FdCase

try:
    FdProblem(FdCase("icidr", "shear", 9).rheology, 9, 30.0)
except NativeUnavailable as err:  # no gcc or no SUNDIALS libraries: the py-pde path is tested elsewhere
    pytest.skip(f"native engine unavailable: {err}", allow_module_level=True)

HEAVY = ("pde", "numba", "scipy", "sympy", "sksundae", "matplotlib")


def run_native(*args, **kwargs):
    """A run that must take the native engine (api.run with engine 'native')."""
    from icidr_pde.api import run

    result = run(*args, engine="native", **kwargs)
    assert result.settings["engine"] == "native"
    return result


def test_catalog_is_what_the_registries_hold():
    from icidr_pde.cli.run import discretization_options
    from icidr_pde.discretizations import DISCRETIZATIONS
    from icidr_pde.engines import JACOBIAN_MODES, METHODS

    assert catalog.DISCRETIZATIONS == tuple(DISCRETIZATIONS)
    assert {k: v[1] for k, v in catalog.DISCRETIZATION_OPTIONS.items()} == discretization_options()
    for key, (defaults, _) in catalog.DISCRETIZATION_OPTIONS.items():
        assert defaults == {n: c.options[key][0] for n, c in DISCRETIZATIONS.items() if key in c.options}
    assert (catalog.METHODS, catalog.JACOBIAN_MODES) == (METHODS, JACOBIAN_MODES)


def test_native_jacobian_is_the_derivative_of_the_native_rates():
    """Fourth-order central differences of the C right-hand side, on a state with u_z != 0 and
    w > 0 everywhere (the stresses and the upwind choice are smooth there)."""
    N = 21
    case = FdCase("icidr", "sine", N)
    problem = FdProblem(case.rheology, N, case.H)
    rng = np.random.default_rng(5)
    y = case.y0 + 1e-3 * rng.standard_normal(case.y0.size)
    y[1::3] = case.z / case.H + 0.05 * np.sin(2 * np.pi * case.z / case.H)  # u_z > 0 on every face
    y[2::3] = 0.03 + 0.01 * np.sin(2 * np.pi * case.z / case.H) + 1e-3 * rng.random(N)  # w > 0.019
    J = problem.jacobian_dense(y)
    e = 1e-5
    for j in range(3 * N):
        d = np.zeros(3 * N)
        d[j] = e * max(1.0, abs(y[j]))
        column = (8 * (problem.rates(y + d) - problem.rates(y - d))
                  - (problem.rates(y + 2 * d) - problem.rates(y - 2 * d))) / (12 * d[j])
        assert np.allclose(J[:, j], column, rtol=1e-6, atol=1e-7 * np.max(np.abs(J))), j


@pytest.mark.parametrize("case", ["icidr-shear", "icidr-sine"])
def test_native_run_reaches_the_references(case):
    """README (presets): CVODE rtol 1e-5 at N = 201 is within 1e-3 of the converged max|w|
    series (the grid's own error is 2.4e-4 and 4.7e-4); mass conserved to round-off."""
    from icidr_pde.studies.references import CASES, reference, series_error, series_times

    spec = CASES[case]
    result = run_native(spec["rheology"], spec["scene"], 201, spec["t_end"], list(series_times(spec["t_end"])))
    assert not result.blew_up and result.t_final == spec["t_end"]
    assert series_error(result, reference(case)) < 1e-3
    assert abs(result.mass_drift) < 1e-14
    assert result.settings["engine"] == "native"
    assert result.n_steps > 0 and result.n_lu > 0 and result.n_jac > 0


def test_native_run_follows_the_py_pde_cvode_run():
    """The same integrator on the same equations: the same steps, series to round-off
    amplified by the tolerance."""
    from icidr_pde.api import run

    a, b = run_native("icidr", "shear", 101, 10.0), run("icidr", "shear", 101, 10.0, method="CVODE")
    assert a.n_steps == b.n_steps
    assert np.array_equal(a.max_w_t, b.max_w_t)
    assert np.allclose(a.max_w_series, b.max_w_series, rtol=1e-5, atol=0)
    assert a.time_labels == b.time_labels and np.allclose(a.w, b.w, rtol=0, atol=1e-7)
    assert np.array_equal(a.chi_t, b.chi_t)
    assert set(a.to_dict()) == set(b.to_dict())


def test_failed_run_returns_what_it_computed():
    """mu(I),Phi(I) at N = 201 blows up (fig 4b): t* as the py-pde path's CVODE finds it, the
    series up to t*, the state at t*, the reason."""
    from icidr_pde.api import run

    result = run_native("mui", "shear", 201, 1.0, ["0", "0.01", "0.5"])
    reference = run("mui", "shear", 201, 1.0, ["0", "0.01", "0.5"], method="CVODE")
    assert result.blew_up and reference.blew_up
    assert result.t_star == pytest.approx(reference.t_star, rel=1e-3)
    assert result.t_final == result.t_star and result.max_w_t[-1] == result.t_star
    assert np.all(np.diff(result.max_w_t) > 0)
    assert result.max_w_series[-1] == pytest.approx(np.max(np.abs(result.final[2])))
    assert result.time_labels == ["0", "0.01"]
    assert "integrator failed" in result.reason
    assert abs(result.mass_drift) < 1e-12


def test_phi_reaching_its_range_is_found_by_the_root_function():
    """The validity root function stops CVODE where phi first reaches the end of its range:
    the sine case compacts (max phi 0.781 at t = 0.1, 0.782 at t = 0.3), so with 0.7815 as
    the upper end the run stops at the crossing, between those times, with max phi on it."""
    case = FdCase("icidr", "sine", 41)
    problem = FdProblem(case.rheology, 41, case.H, bounds=(0.0, 0.7815))
    problem.start(case.y0, rtol=1e-7, atol=1e-10)
    times = np.linspace(0.05, 2.0, 40)
    max_w, states = np.empty(times.size), np.empty((1, case.y0.size))
    done, status, _ = problem.advance(times, np.full(times.size, -1), max_w, states)
    t, y = problem.last_good()
    assert status == 1 and 0 < done < times.size
    assert times[done - 1] <= t < times[done] and 0.1 < t < 0.3
    assert y[0::3].max() == pytest.approx(0.7815, abs=1e-9)


def child(code):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    return proc


def cli_in_fresh_process(argv):
    """`icidr-pde argv` in a new interpreter: (process, exit status, top-level modules it imported)."""
    code = (f"import sys, json, icidr_pde.cli\nstatus = icidr_pde.cli.main({argv!r})\n"
            "print(json.dumps([status, sorted({m.split('.')[0] for m in sys.modules})]))")
    proc = child(code)
    status, modules = json.loads(proc.stdout.strip().splitlines()[-1])
    return proc, status, modules


def test_warm_cli_run_imports_no_heavy_library(tmp_path):
    from icidr_pde import cli

    argv = ["run", "--N", "11", "--t-end", "0.5", "--no-progress"]
    assert cli.main(argv + ["--json", str(tmp_path / "warm.json")]) == 0  # builds the library if missing
    target = tmp_path / "r.json"
    proc, status, modules = cli_in_fresh_process(argv + ["--json", str(target)])
    assert status == 0, proc.stderr
    assert "compiling" not in proc.stderr
    assert not set(HEAVY) & set(modules), set(HEAVY) & set(modules)
    data = json.loads(target.read_text())
    assert data["settings"]["engine"] == "native" and data["t_final"] == 0.5
    pde_path = tmp_path / "p.json"
    assert cli.main(argv + ["--json", str(pde_path), "--engine", "pde"]) == 0
    assert set(json.loads(pde_path.read_text())) == set(data)


def test_failed_cli_run_exits_3_with_its_json(tmp_path):
    from icidr_pde import cli

    target = tmp_path / "t.json"
    assert cli.main(["run", "--rheology", "mui", "--N", "201", "--t-end", "1", "--no-progress",
                     "--json", str(target)]) == 3
    data = json.loads(target.read_text())
    assert data["blew_up"] and data["settings"]["engine"] == "native" and 0 < data["t_star"] < 0.05


def test_fallback_says_why_in_one_line(capsys):
    from icidr_pde import cli

    assert cli.main(["run", "--method", "LSODA", "--N", "9", "--t-end", "0.05", "--no-progress",
                     "--engine", "native"]) == 0
    err = capsys.readouterr().err
    assert "native engine not used: method 'LSODA'" in err
    assert cli.main(["run", "--method", "BDF", "--N", "9", "--t-end", "0.05", "--no-progress"]) == 0
    assert "native engine" not in capsys.readouterr().err  # auto: silent where it does not apply


def test_law_without_a_c_form_falls_back():
    """The scalar flow-rule solve (icidr-blended-quarter) has no C form here: the native engine says so."""
    from icidr_pde.rheology import get_rheology
    from icidr_pde.native.build import library

    with pytest.raises(NativeUnavailable, match="scalar flow-rule solve"):
        library(get_rheology("icidr-blended-quarter"), __import__("icidr_pde.rheology").rheology.SHEAR_CELL)


@pytest.mark.slow  # compiles the law's numba kernels for this run alone: ~15 s
def test_law_without_a_c_form_runs_on_the_pde_path():
    """auto then takes the py-pde path (SUNDIALS through scikit-sundae) and runs it to t_end."""
    from icidr_pde.api import run

    result = run("icidr-blended-quarter", "shear", 11, 0.05, engine="auto")
    assert result.settings["engine"] == "sundae" and result.t_final == 0.05


def test_bad_input_is_named_before_any_work():
    from icidr_pde.validation import ParameterError

    with pytest.raises(ParameterError, match="`N`"):
        run_native("icidr", "shear", 2, 1.0)
    with pytest.raises(ValueError, match="`advection`"):
        run_native("icidr", "shear", 11, 1.0, advection="sideways")
    with pytest.raises(ValueError, match="`t_end`"):
        run_native("icidr", "shear", 11, -1.0)
    from icidr_pde.cells import choice_asks
    from icidr_pde.engines.choose import choose

    choice = choose(method="BDF", request="native", **choice_asks("fd", request="native"))
    assert choice.engine == "scipy" and "method 'BDF'" in choice.reason


@pytest.mark.parametrize("sig, status", [(__import__("signal").SIGINT, 130), (__import__("signal").SIGTERM, 143)])
def test_signal_stops_a_native_run_with_its_results(tmp_path, sig, status):
    """Ctrl-C or SIGTERM between two chunks of output times: the CLI writes what was computed
    up to the time reached and exits 130/143 (the native run is in C between the chunks)."""
    from tests.test_hardening import wait_for_progress

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.Popen([sys.executable, "-m", "icidr_pde.cli", "run", "--scene", "sine", "--N", "1601",
                             "--t-end", "1e5", "--json", "i.json"], cwd=tmp_path, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        seen = wait_for_progress(proc)
        proc.send_signal(sig)
        proc.wait(timeout=120)
    finally:
        proc.kill()
    assert "native" in seen
    assert proc.returncode == status
    summary = json.loads((tmp_path / "i.json").read_text())
    assert summary["reason"].startswith("interrupted") and summary["settings"]["engine"] == "native"
    assert 0 < summary["t_final"] < 1e5 and not summary["blew_up"]
    assert abs(summary["mass_drift"]) < 1e-13  # the state at t_final, not another output's


def test_without_a_compiler_the_run_falls_back_saying_why(tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), CC=str(tmp_path / "no-such-cc"))
    proc = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "run", "--N", "9", "--t-end", "0.1",
                           "--no-progress", "--json", str(tmp_path / "r.json")], env=env, capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if "native engine" in line]
    assert len(lines) == 1 and "no C compiler" in lines[0] and "py-pde path" in lines[0]
    assert json.loads((tmp_path / "r.json").read_text())["settings"]["engine"] == "sundae"


def test_interrupt_keeps_the_state_at_the_time_reached(monkeypatch):
    """Ctrl-C between two calls into C: the Result holds CVODE's last step, past the last output,
    the same state as a run asked for a snapshot at its time (output times do not change CVODE's
    steps)."""
    original, calls = FdProblem.advance, []

    def advance(self, *args):
        calls.append(1)
        if len(calls) > 3:
            raise KeyboardInterrupt
        return original(self, *args)

    monkeypatch.setattr(FdProblem, "advance", advance)
    stopped = run_native("icidr", "sine", 41, 20.0)
    monkeypatch.undo()
    assert stopped.reason.startswith("interrupted") and not stopped.blew_up and 0 < stopped.t_final < 20.0
    assert stopped.max_w_t[-1] < stopped.t_final
    full = run_native("icidr", "sine", 41, 20.0, [0.0, stopped.t_final])
    assert full.times[-1] == stopped.t_final
    assert np.array_equal(np.array(stopped.final), np.array([full.phi[-1], full.u[-1], full.w[-1]]))
