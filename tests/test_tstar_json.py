"""The ``tstar --json`` document (icidr_pde.studies.failure_time.tstar_report): one form for any
number of discretizations, each with the settings its runs used beside t*(N) and the reason each
N failed; ``tstar --load`` reads it back (and the earlier flat and per-discretization forms).

Truth: the same cases run by :func:`icidr_pde.api.run` (its Result's fields), not values typed
here. mu(I) shear on finite volumes: N = 21 reaches t = 0.2, N = 101 fails near 0.06 (fig 4b).
"""

from __future__ import annotations

import json
import warnings

import pytest

from icidr_pde import cli
from icidr_pde.api import run
from icidr_pde.studies.failure_time import SETTINGS, TSTAR_SCHEMA, read_tstar_curves, tstar_report

ARGV = ["tstar", "--rheology", "mui", "--scene", "shear", "--accuracy", "paper", "--jobs", "1", "--no-progress"]


def _result(disc, N, t_end):
    """The run a sweep of ``--accuracy paper`` makes, by the API itself."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return run("mui", "shear", N, t_end, [0.0], discretization=disc, method="BDF", rtol=1e-6, atol=1e-9,
                   engine="pde", series_times=())


def _settings_of(result):
    fields = result.to_dict()
    return {key: fields["settings"][key] if key in ("engine", "linear_solver") else fields[key]
            for key in SETTINGS}


@pytest.fixture(scope="module")
def one(tmp_path_factory):
    out = tmp_path_factory.mktemp("one") / "fd.json"
    assert cli.main(ARGV + ["--discretization", "fd", "--N", "21,101", "--t-end", "0.2", "--json", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    out = tmp_path_factory.mktemp("two") / "both.json"
    assert cli.main(ARGV + ["--discretization", "fd", "cheb", "--N", "21,23", "--t-end", "0.001",
                            "--json", str(out)]) == 0
    return out


def test_one_discretization_records_settings_tstar_and_reasons(one):
    doc = json.loads(one.read_text())
    assert doc["schema"] == TSTAR_SCHEMA and list(doc["discretizations"]) == ["fd"]
    entry = doc["discretizations"]["fd"]
    assert set(entry) == {"settings", "settings_by_N", "t_star", "reason"}
    decays, fails = _result("fd", 21, 0.2), _result("fd", 101, 0.2)
    assert not decays.blew_up and fails.blew_up  # the cases are what the test says they are
    assert entry["t_star"] == {"21": None, "101": fails.t_star}
    assert entry["reason"] == {"21": None, "101": fails.reason}
    assert entry["settings"] == _settings_of(decays) == _settings_of(fails)
    assert entry["settings_by_N"] == {}


def test_two_discretizations_have_the_same_form_each_with_its_own_settings(two):
    doc = json.loads(two.read_text())
    assert doc["schema"] == TSTAR_SCHEMA and list(doc["discretizations"]) == ["fd", "cheb"]
    for disc, entry in doc["discretizations"].items():
        results = {N: _result(disc, N, 0.001) for N in (21, 23)}
        assert entry["t_star"] == {str(N): r.t_star for N, r in results.items()} == {"21": None, "23": None}
        assert entry["reason"] == {"21": None, "23": None}
        assert entry["settings"] == _settings_of(results[21]) == _settings_of(results[23])
    fd, cheb = (doc["discretizations"][d]["settings"] for d in ("fd", "cheb"))
    assert fd["linear_solver"] != cheb["linear_solver"]  # recorded per discretization, not shared


def test_a_setting_that_differs_between_N_is_given_per_N():
    runs = {21: dict(N=21, t_star=None, reason="reached t_end", linear_solver="dense LU", rtol=1e-7),
            201: dict(N=201, t_star=0.0105, reason="integrator failed", linear_solver="GMRES", rtol=1e-7)}
    entry = tstar_report({"cheb": runs})["discretizations"]["cheb"]
    assert entry["settings"]["rtol"] == 1e-7 and "linear_solver" not in entry["settings"]
    assert entry["settings_by_N"] == {"linear_solver": {"21": "dense LU", "201": "GMRES"}}
    assert entry["reason"] == {"21": None, "201": "integrator failed"}


def test_load_reads_the_document_back(one, two, tmp_path, monkeypatch):
    from icidr_pde.figures import tstar_plot

    plotted = {}
    monkeypatch.setattr(tstar_plot, "plot_tstar", lambda curves, path, **kw: plotted.update(curves))
    assert cli.main(["tstar", "--load", f"a={one}", "--load", f"b={two}", "--plot", str(tmp_path / "p.png")]) == 0
    docs = {"a": json.loads(one.read_text()), "b": json.loads(two.read_text())}
    assert plotted == {"a": docs["a"]["discretizations"]["fd"]["t_star"],
                       "b fd": docs["b"]["discretizations"]["fd"]["t_star"],
                       "b cheb": docs["b"]["discretizations"]["cheb"]["t_star"]}


@pytest.mark.parametrize("document, curves", [
    ({"21": None, "101": 0.06}, {"": {"21": None, "101": 0.06}}),
    ({"fd": {"21": None}, "cheb": {"21": 0.5}}, {"fd": {"21": None}, "cheb": {"21": 0.5}}),
], ids=["flat", "per-discretization"])
def test_load_reads_the_earlier_forms(document, curves, tmp_path, capsys):
    assert read_tstar_curves(document) == curves
    saved = tmp_path / "old.json"
    saved.write_text(json.dumps(document))
    plot = tmp_path / "p.png"
    assert cli.main(["tstar", "--load", f"x={saved}", "--plot", str(plot)]) == 0
    assert plot.stat().st_size > 0


def test_load_of_another_schema_is_refused_in_one_line(tmp_path, capsys):
    saved = tmp_path / "future.json"
    saved.write_text(json.dumps({"schema": "icidr-pde tstar 3", "discretizations": {}}))
    assert cli.main(["tstar", "--load", f"x={saved}", "--plot", str(tmp_path / "p.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--load" in err[0] and TSTAR_SCHEMA in err[0] and "icidr-pde tstar 3" in err[0]


def test_the_documented_example_has_the_written_form(one):
    """docs/cli.md's example is the document of its command, up to the numbers of the run."""
    import re
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text(encoding="utf-8")
    section = doc.split("## What `tstar --json` writes", 1)[1]
    example = json.loads(re.search(r"```json\n(.*?)```", section, re.S).group(1))
    written = json.loads(one.read_text())
    t_doc, t_run = (d["discretizations"]["fd"].pop("t_star") for d in (example, written))
    assert example == written  # the command it names is the fixture's
    assert t_doc.keys() == t_run.keys() and t_doc["21"] is None is t_run["21"]
    assert t_doc["101"] == pytest.approx(t_run["101"], rel=1e-3)  # t* moves with the round-off of the solves


def test_the_gallery_reads_a_sweep_in_either_form(one, tmp_path, monkeypatch):
    """fig 4(b) of the gallery reads data/tstar/: the committed flat files and this document."""
    import numpy as np

    from icidr_pde.figures import paper

    (tmp_path / "tstar").mkdir()
    (tmp_path / "tstar" / "new.json").write_text(one.read_text())
    flat = json.loads(one.read_text())["discretizations"]["fd"]["t_star"]
    (tmp_path / "tstar" / "old.json").write_text(json.dumps(flat))
    monkeypatch.setattr(paper, "DATA", tmp_path)
    (N_new, t_new), (N_old, t_old) = paper._load_tstar("new.json"), paper._load_tstar("old.json")
    assert list(N_new) == list(N_old) == [21, 101]
    np.testing.assert_array_equal(t_new, t_old)
    assert np.isnan(t_new[0]) and t_new[1] == flat["101"]


def test_a_law_file_is_taken_as_run_takes_it(tmp_path, capsys):
    """``tstar --rheology FILE`` runs the law of the file, in the worker processes too (the settings of
    the document are those of the API's run of that file), and refuses a file that cannot be used
    in one line, exit 2, before any run."""
    from pathlib import Path

    law = Path(__file__).resolve().parents[1] / "examples" / "half_rate_law.toml"
    out = tmp_path / "law.json"
    argv = ["tstar", "--rheology", str(law), "--scene", "sine", "--discretization", "fd", "--N", "11",
            "--t-end", "0.02", "--accuracy", "paper", "--jobs", "2", "--no-progress"]
    assert cli.main(argv + ["--json", str(out)]) == 0
    entry = json.loads(out.read_text())["discretizations"]["fd"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = run(str(law), "sine", 11, 0.02, [0.0], discretization="fd", method="BDF", rtol=1e-6, atol=1e-9,
                     engine="pde", series_times=())
    assert entry["settings"] == _settings_of(result)
    assert entry["settings"]["rheology"] == "half-rate-toml"  # the file's name for its law, not the default mui
    assert entry["t_star"] == {"11": result.t_star}
    capsys.readouterr()
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nyield_function = "M * p * import_os"\n')
    for rheology in (str(bad), str(tmp_path / "missing.toml")):
        assert cli.main([*argv[:2], rheology, *argv[3:], "--json", str(tmp_path / "no.json")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("icidr-pde: error:") and rheology in err, err
        assert not (tmp_path / "no.json").exists()


def _cases():
    """The cases of the `one` fixture's command, as run_many takes them (keyword arguments of api.run)."""
    return [dict(rheology="mui", scene="shear", N=N, t_end=0.2, times=[0.0], discretization="fd", method="BDF",
                 rtol=1e-6, atol=1e-9, engine="pde", backend="numpy", series_times=()) for N in (101, 21)]


def test_run_many_results_make_the_document_the_command_writes(one):
    """tstar_report of run_many's Results (in this process) is the command's document for the same
    cases, whatever their order; a case whose run raised is refused in one line."""
    from icidr_pde.studies.distributed import run_many

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = run_many(_cases())
    assert tstar_report(results) == json.loads(one.read_text())
    bad = run_many([dict(rheology="no-such-law", N=21, t_end=0.01)])
    with pytest.raises(ValueError, match=r"`results\[1\]` must be a Result"):
        tstar_report([results[0], *bad])
