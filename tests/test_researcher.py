"""Regression tests of issue 41 ("What a researcher meets"): what a new user of the toolkit
runs into, each reproduced through the public API or the command line (``icidr_pde.cli.main``
in process)."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde import cli


@pytest.fixture(scope="module")
def mui_failed():
    """mu(I) on scene shear at N = 101 fails at t* ~ 0.06, before its first default snapshot after 0."""
    res = run("mui", "shear", N=101, t_end=1)
    assert res.blew_up and list(res.times) == [0.0]
    return res


def _lines(fig):
    return [line for ax in fig.axes for line in ax.get_lines()]


def test_failed_run_keeps_the_last_states_before_t_star(mui_failed):
    res = mui_failed
    t = res.last_times
    assert 3 <= t.size <= 6 and np.all(np.diff(t) > 0) and 0.5 * res.t_star < t[0] and t[-1] < res.t_star
    assert res.last_states.shape == (t.size, 3, res.N)
    # the states are the run's own: max|w| there is the series' value at that time
    in_series = [(k, state) for time, state in zip(t, res.last_states)
                 for k in np.flatnonzero(res.max_w_t == time)]
    assert len(in_series) >= 3
    for k, state in in_series:
        assert np.max(np.abs(state[2])) == pytest.approx(res.max_w_series[k], rel=1e-12)


def test_plot_of_a_failed_run_draws_the_state_at_t_star_and_before(mui_failed):
    from icidr_pde.plotting import plot_result

    res = mui_failed
    fig = plot_result(res)
    drawn = [np.asarray(line.get_ydata()) for line in _lines(fig) if len(line.get_ydata()) == res.N]
    assert any(np.array_equal(y, res.final[2]) for y in drawn), "w at t* not drawn"
    assert any(np.array_equal(y, res.final[0]) for y in drawn), "phi at t* not drawn"
    before = [k for k, state in enumerate(res.last_states) if any(np.array_equal(y, state[2]) for y in drawn)]
    assert len(before) >= 3, "the last states before t* are not drawn"


def test_plot_of_a_failed_2d_run_draws_the_failure():
    from icidr_pde.plotting import plot_result

    res = run("mui", "bump2d", N=(32, 32), t_end=2)
    assert res.blew_up and res.last_times.size and res.last_states.shape[1:] == (3, 32, 32)
    fig = plot_result(res)
    images = [np.asarray(im.get_array()) for ax in fig.axes for im in ax.get_images()]
    assert any(np.array_equal(a, np.asarray(res.final[2]).T) for a in images), "w at t* not drawn"
    assert any(np.array_equal(a, np.asarray(res.last_states[-1][2]).T) for a in images)
    titles = " ".join(ax.get_title() for ax in fig.axes)
    assert f"t = {res.t_star:.4g}" in titles


# --- item 2: law check reports the CIDR conditions and the symbol separately ---------------

K_LAW = """name = "researcher-k"
yield_function = "M * I / Psi * p"
dilatancy_function = "k * M * (I / Psi - Psi / I)"
[parameters]
k = 0.5
"""


@pytest.fixture(scope="module")
def k_law(tmp_path_factory):
    path = tmp_path_factory.mktemp("laws") / "researcher-k.toml"
    path.write_text(K_LAW)
    return path


def test_law_failing_43_but_with_a_negative_symbol_is_reported_well_posed(k_law):
    import sympy as sp

    from stability.workbench import law_report

    report = law_report(str(k_law), with_curves=False)
    c43 = report["conditions"]["(4.3)"]
    # by hand: Y = M I p/Psi, f = k M (I/Psi - Psi/I): Y_p - I/(2p) Y_I - (f + I f_I) = M I/Psi (1/2 - 2k)
    I, M, Psi = sp.symbols("I M Psi", positive=True)
    assert sp.simplify(sp.sympify(c43["expression"], locals=dict(I=I, M=M, Psi=Psi)) + I * M / (2 * Psi)) == 0
    assert (c43["status"], c43["method"]) == ("fails", "symbolic")
    assert report["conditions_hold"] is False
    assert report["stability"]["one_d"]["well_posed"] and report["stability"]["two_d"]["well_posed"]
    assert report["well_posed"] is True  # the symbol's verdict; (4.3)-(4.5) are only sufficient


def test_law_check_prints_the_conditions_and_the_symbol_separately(k_law, capsys):
    assert cli.main(["law", "check", str(k_law), "--no-curves"]) == 0
    out = capsys.readouterr().out
    assert "(4.3): fails (symbolic: -I*M/(2*Psi) != 0)" in out
    assert "CIDR conditions (4.3)-(4.5), sufficient: not shown ((4.3))" in out
    assert "verdict: WELL-POSED (the symbol at the 312 sampled states)" in out


def test_run_says_in_one_line_that_a_law_file_fails_its_check(k_law, tmp_path, capsys):
    status = cli.main(["run", "--rheology", str(k_law), "--scene", "sine", "--t-end", "0.01", "--no-progress"])
    assert status == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "researcher-k" in line and "(4.3)" in line]
    assert len(err) == 1 and "(4.3) fails" in err[0] and "well-posed at the 312 sampled states" in err[0]
    good = tmp_path / "researcher-icidr.toml"  # iCIDR itself: k = 1/4, (4.3)-(4.5) hold
    good.write_text(K_LAW.replace("researcher-k", "researcher-icidr").replace("0.5", "0.25"))
    assert cli.main(["run", "--rheology", str(good), "--scene", "sine", "--t-end", "0.01", "--no-progress"]) == 0
    assert "(4.3)" not in capsys.readouterr().err


def test_symbol_of_a_fresh_law_file_does_not_hang(tmp_path):
    """Generating a law's kernels loads its material's functions under the same lock."""
    import subprocess
    import sys
    from pathlib import Path

    law = tmp_path / "researcher-fresh.toml"
    law.write_text(K_LAW.replace("researcher-k", "researcher-fresh"))
    code = ("from icidr_pde.rheology.law_files import load_law_file; from stability.workbench import symbol_grid; "
            f"print(symbol_grid(load_law_file({str(law)!r})(None)).phi.size)")
    root = Path(__file__).resolve().parents[1]
    done = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=120,
                          env=dict(__import__("os").environ, PYTHONPATH=str(root)))
    assert done.returncode == 0 and done.stdout.strip() == "312", done.stderr


# --- item 3: no silent dense Newton matrix on the 2-D cell ----------------------------------

def _choose_2d(cells=64 * 64, **kw):
    from icidr_pde.cells import choice_asks
    from icidr_pde.engines.choose import choose

    return choose(request="pde", **choice_asks("fv2d", request="pde", cells=cells), **kw)


def _suggested(message):
    """(method, jacobian) pairs an error suggests: "with --method M: --jacobian a or b; ..." or "use 'a' or 'b' with method 'M'"."""
    import re

    pairs = []
    for method, modes in re.findall(r"with --method (\w+): --jacobian ([\w-]+(?: or [\w-]+)*)", message):
        pairs += [(method, m) for m in modes.split(" or ")]
    found = re.search(r"use ((?:'[\w-]+'(?: or )?)+) with method '(\w+)'", message)
    if found:
        pairs += [(found.group(2), m) for m in re.findall(r"'([\w-]+)'", found.group(1))]
    return pairs


@pytest.mark.parametrize("method, jacobian", [("CVODE", "analytic"), ("CVODE", "none"), ("LSODA", None),
                                              ("BDF", "none"), ("CVODE", "banded-fd")])
def test_dense_or_impossible_2d_choices_are_refused_with_choices_that_work(method, jacobian):
    from icidr_pde.engines.choose import DENSE_2D_CELLS
    from icidr_pde.validation import ParameterError

    with pytest.raises(ParameterError) as err:
        _choose_2d(method=method, jacobian=jacobian)
    pairs = _suggested(str(err.value))
    assert pairs, str(err.value)
    for m, j in pairs:  # every suggestion is taken, and is not a dense LU
        assert "dense" not in _choose_2d(method=m, jacobian=j).linear_solver
    if jacobian != "banded-fd":  # allowed on a small grid
        assert "dense" in _choose_2d(cells=DENSE_2D_CELLS, method=method, jacobian=jacobian).linear_solver


def test_cli_refuses_the_dense_2d_solver_in_one_line(capsys):
    assert cli.main(["run", "--scene", "bump2d", "--Nx", "64", "--Nz", "64", "--jacobian", "analytic",
                     "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "dense" in err and "'fourier'" in err and "12288 unknowns" in err


def test_help_and_cli_doc_list_the_same_2d_choices(capsys):
    import re
    from pathlib import Path

    from icidr_pde.engines.choose import CHOICES_2D, DENSE_2D_CELLS

    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    help_text = " ".join(capsys.readouterr().out.split())
    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text()
    for method, modes in CHOICES_2D.items():
        assert all(f"'{m}'" in help_text for m in modes), method
    doc_2d = re.search(r"--scene bump2d.*?(?=\nicidr-pde run \.\.\.)", doc, re.S).group(0)
    assert set(re.search(r"--jacobian \{([^}]*)\}", doc_2d).group(1).split(",")) == set(CHOICES_2D["CVODE"])
    side = re.search(r"BDF/Radau: (.*?); dense", " ".join(doc_2d.replace("#", "").split())).group(1)
    assert set(re.findall(r"[\w-]+", side.replace(" or ", " "))) == set(CHOICES_2D["BDF"])
    assert f"{int(DENSE_2D_CELLS ** 0.5)}x{int(DENSE_2D_CELLS ** 0.5)} cells" in doc_2d
    assert f"beyond {DENSE_2D_CELLS} cells" in help_text


# --- item 7: errors that name the real problem ----------------------------------------------

def _one_error(capsys, argv):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


def test_nx_on_a_1d_scene_says_the_scene_is_1d(capsys):
    err = _one_error(capsys, ["run", "--scene", "shear", "--Nx", "64", "--no-progress"])
    assert "`--Nx`" in err and "'shear' is 1-D" in err and "--N" in err and "(64, 64)" not in err


def test_a_time_beyond_t_end_says_so(capsys):
    err = _one_error(capsys, ["run", "--times", "20", "--no-progress"])
    assert "got 20 (> t_end = 10)" in err and "str" not in err


# --- item 5: wall_s is the solve's, the Jacobian's compilation is set-up ---------------------

def test_the_jacobian_is_compiled_in_the_set_up_not_the_solve(monkeypatch):
    """The compiled Jacobian's first call compiles it (seconds on an empty cache): it is made
    before the timed solve starts, so that wall_s excludes it (compile_s has it)."""
    import dataclasses

    import icidr_pde.api as api
    import icidr_pde.engines.stiff as stiff

    calls, seen = [], []
    scheme_problem, drive = stiff.scheme_problem, api.drive

    def counted_problem(*args, **kwargs):
        problem, ordering = scheme_problem(*args, **kwargs)
        jac = problem.jacobian.jac

        def counted(t, y):
            calls.append(t)
            return jac(t, y)

        spec = dataclasses.replace(problem.jacobian, jac=counted)
        return dataclasses.replace(problem, jacobian=spec), ordering

    def watched_drive(*args, **kwargs):
        seen.append(len(calls))
        return drive(*args, **kwargs)

    monkeypatch.setattr(stiff, "scheme_problem", counted_problem)
    monkeypatch.setattr(api, "drive", watched_drive)
    res = run("icidr", "shear", N=21, t_end=0.1, method="BDF")
    assert res.settings["engine"] == "scipy" and seen == [1] and len(calls) > 1


# --- item 4: numbers quoted in the docs are the code's ---------------------------------------

DOCS = __import__("pathlib").Path(__file__).resolve().parents[1] / "docs"


def _paragraphs():
    for path in sorted(DOCS.glob("*.md")):
        for paragraph in path.read_text(encoding="utf-8").split("\n\n"):
            yield path.name, " ".join(paragraph.split())


PACKAGES = ("engines", "engines.linear", "cells", "discretizations", "dem", "rheology", "studies", "native", "figures", "movies")


def test_quoted_constants_name_code_that_exists():
    """`engines.base.KRYLOV_EPS_LIN` and the like: each dotted name ending in a CONSTANT resolves."""
    import importlib
    import re

    missing = []
    for name, text in _paragraphs():
        for dotted in set(re.findall(r"`((?:[a-z_0-9]+\.)+[A-Z][A-Z_0-9]+)`", text)):
            module, _, constant = dotted.rpartition(".")
            found = False  # the docs abbreviate: choose.X is icidr_pde.engines.choose.X
            for candidate in [module, f"icidr_pde.{module}"] + [f"icidr_pde.{package}.{module}" for package in PACKAGES]:
                try:
                    found = found or hasattr(importlib.import_module(candidate), constant)
                except ImportError:
                    pass
            if not found:
                missing.append((name, dotted))
    assert not missing


def test_the_native_fv2d_threshold_quoted_is_the_code_s():
    import re

    from icidr_pde.cells import get_cell

    NATIVE_FV2D_AUTO_CELLS = get_cell("plane2d").native_auto_cells
    quoted = [(name, m) for name, text in _paragraphs() if "Plane2D.native_auto_cells" in text
              for m in re.findall(r"up to (\d+)²(?: = (\d+) cells)?", text)]
    assert quoted
    for name, (n, cells) in quoted:
        assert int(n) ** 2 == NATIVE_FV2D_AUTO_CELLS and cells in ("", str(NATIVE_FV2D_AUTO_CELLS)), name


def test_the_bump2d_t_star_in_results_is_the_gallery_s():
    import json
    import re

    numbers = json.loads((DOCS / "figures" / "numbers.json").read_text())
    t_star = numbers["figures"]["bump2d"]["t_star_mui"]
    quoted = re.search(r"μ\(I\) on 64² at 98 % of its t\* = ([0-9.]+)", " ".join((DOCS / "results.md").read_text().split()))
    assert float(quoted.group(1)) == pytest.approx(t_star, abs=5e-4)


# --- items 8, 9: the 2-D py-pde class first-class, a clean namespace ------------------------

def test_the_2d_class_is_exported_and_its_make_state_takes_f_of_x_and_z():
    import icidr_pde
    from icidr_pde import ShearCell2DPDE

    eq = ShearCell2DPDE("icidr")
    grid = eq.make_grid((8, 6), H=30)
    state = eq.make_state(grid, 0.78, lambda x, z: z / 30, "0.01 * sin(2 * pi * x / 30)")
    xz = eq.nodes(grid)
    assert np.allclose(state.data[1], xz[..., 1] / 30)
    assert np.allclose(state.data[2], 0.01 * np.sin(2 * np.pi * xz[..., 0] / 30))
    assert np.all(state.data[0] == 0.78)
    assert "ShearCell2DPDE" in icidr_pde.__all__


def test_dir_lists_public_names_only():
    import icidr_pde

    assert {"annotations", "importlib"}.isdisjoint(dir(icidr_pde))
    assert set(icidr_pde.__all__) <= set(dir(icidr_pde))


def test_result_plots_itself_and_names_its_final_fields(mui_failed):
    res = mui_failed
    phi, u, w = res.final
    assert res.final.w is w and res.final.phi is phi and res.final[1] is u
    fig = res.plot()
    assert any(np.array_equal(line.get_ydata(), res.final.w) for line in _lines(fig))


# --- items 6, 10: the small ones -------------------------------------------------------------

def test_dem_help_states_each_default_once(capsys):
    import re

    for command in ("steady", "transient", "pool", "audit"):
        with pytest.raises(SystemExit):
            cli.main(["dem", command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        for option_help in re.split(r"\s--", text):
            assert len(re.findall(r"\(default: ", option_help)) <= 1, option_help


def test_dem_ctrl_c_is_one_line_not_a_traceback(monkeypatch, capsys):
    import icidr_pde.cli.dem as dem_cli

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(dem_cli, "cmd_steady", interrupted)
    wrapped = dem_cli._needs_lammps(dem_cli.cmd_steady)

    class Args:
        dem_command = "steady"

    assert wrapped(Args()) == 130
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "interrupted" in err


def test_tstar_says_no_failure_rather_than_null(capsys, tmp_path):
    assert cli.main(["tstar", "--rheology", "icidr", "--N", "21:23:2", "--t-end", "0.05", "--no-progress",
                     "--cache", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "null" not in out and "no failure by --t-end" in out


def test_readme_says_how_long_the_tests_and_dem_steady_take():
    from pathlib import Path

    lines = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8").splitlines()
    assert any("python -m pytest" in line and "min" in line.partition("#")[2] for line in lines[:8])
    assert any(line.startswith("icidr-pde dem steady") and "min" in line.partition("#")[2] for line in lines)


def test_law_check_says_what_it_is_doing_at_a_terminal(k_law, capsys, monkeypatch):
    import sys

    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert cli.main(["law", "check", str(k_law), "--no-curves"]) == 0
    captured = capsys.readouterr()
    stages = [line for line in captured.err.splitlines() if line.startswith("law check: ")]
    assert len(stages) >= 3 and "law check:" not in captured.out
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)  # a log or a pipe: the report only
    assert cli.main(["law", "check", str(k_law), "--no-curves"]) == 0
    assert "law check:" not in capsys.readouterr().err


def test_verify_tells_each_group_as_it_starts(monkeypatch):
    from stability import report

    for module in (report.rheologies, report.cidr, report.icidr, report.linearize, report.mui, report.dissipation):
        monkeypatch.setattr(module, "checks", lambda: [])
    monkeypatch.setattr(report, "crosscheck_rows", lambda: [])
    told = []
    assert report.run_checks(True, told.append) == []
    assert told[0].startswith("verify [1/8]") and len(told) == 7 and "cross-checks" in told[-1]
