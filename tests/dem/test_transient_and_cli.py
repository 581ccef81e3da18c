"""Ensemble statistics, error definition, bin averaging and CLI wiring (no LAMMPS)."""

import argparse

import numpy as np
import pytest

from icidr_pde.dem import transient
from icidr_pde.cli.dem import add_parser


def _fake_runs(R=4, T=3, B=15):
    rng = np.random.default_rng(0)
    runs = []
    for _ in range(R):
        runs.append({"tr_times": np.arange(T) * 0.1, "z": np.arange(B) * 2.0 + 1.0, "phi0": 0.78,
                     "H": 30.0, "tr_a": 0.16, "tr_b": 0.1,
                     "tr_phi": 0.78 + rng.normal(0, 0.01, (T, B)),
                     "tr_u": rng.normal(0, 0.01, (T, B)), "tr_w": rng.normal(0, 0.01, (T, B))})
    return runs


def test_ensemble_mean_std():
    runs = _fake_runs()
    ens = transient.ensemble(runs)
    stack = np.stack([r["tr_u"] for r in runs])
    np.testing.assert_allclose(ens["u_mean"], stack.mean(0))
    np.testing.assert_allclose(ens["u_std"], stack.std(0, ddof=1))
    np.testing.assert_allclose(ens["max_w"], np.abs(np.stack([r["tr_w"] for r in runs]).mean(0)).max(1))
    assert ens["repeats"] == 4
    with pytest.raises(ValueError, match="results"):
        transient.ensemble([{"phi0": 0.78}])


def test_error_definition_on_known_offsets():
    ens = transient.ensemble(_fake_runs())
    cont = {f: ens[f"{f}_mean"].copy() for f in ("phi", "u", "w")}
    cont["u"] = cont["u"] + 0.03          # uniform offset of 3 % of V0
    cont["phi"] = cont["phi"] + 0.0078    # 1 % of phi0
    e = transient.errors(ens, cont)
    np.testing.assert_allclose(e["u"], 0.03)
    np.testing.assert_allclose(e["phi"], 0.01)
    np.testing.assert_allclose(e["w"], 0.0, atol=1e-15)
    np.testing.assert_allclose(e["total"], 0.03)


def test_bin_average_of_linear_and_sine_profiles():
    z = np.linspace(0, 30, 2001)
    edges = np.linspace(0, 30, 16)
    np.testing.assert_allclose(transient.bin_average(z, 2 * z + 1, edges, 30.0),
                               2 * (edges[1:] + edges[:-1]) / 2 + 1, rtol=1e-10)
    k = 2 * np.pi / 30
    exact = (np.cos(k * edges[:-1]) - np.cos(k * edges[1:])) / (k * 2.0)
    np.testing.assert_allclose(transient.bin_average(z, np.sin(k * z), edges, 30.0), exact, atol=2e-6)


def test_cli_wiring_and_bad_input():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    add_parser(sub)
    a = parser.parse_args(["dem", "steady", "--phi0", "0.76", "0.8", "--repeats", "3", "--jobs", "1"])
    assert a.phi0 == [0.76, 0.8] and a.repeats == 3 and callable(a.func)
    b = parser.parse_args(["dem", "transient", "--repeats", "2"])
    assert b.repeats == 2 and callable(b.func) and b.func is not a.func
    with pytest.raises(SystemExit):
        parser.parse_args(["dem", "steady", "--repeats", "0"])


def _parse(argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    add_parser(sub)
    return parser.parse_args(argv)


def test_default_outputs_go_to_the_current_directory_not_the_committed_data(tmp_path, monkeypatch):
    from icidr_pde.cli.dem import _output, _writable_dir
    from icidr_pde.dem.paths import committed_dir

    monkeypatch.chdir(tmp_path)
    for argv, name in ((["dem", "steady"], "steady.json"), (["dem", "transient"], "transient.json")):
        a = _parse(argv)
        out = _writable_dir(a.out)
        path = _output(a.json, out, name).resolve()
        assert path == tmp_path / name
        assert committed_dir().resolve() not in path.parents
    assert _output("", tmp_path, "x.png") is None
    with pytest.raises(ValueError, match="directory"):
        _output(str(tmp_path), tmp_path, "x.json")          # an existing directory as a file name
    (tmp_path / "afile").write_text("")
    with pytest.raises(ValueError, match="--out"):
        _writable_dir(tmp_path / "afile")


def test_transient_reads_the_committed_fit_from_any_directory(tmp_path, monkeypatch):
    import json

    from icidr_pde.dem.paths import committed

    monkeypatch.chdir(tmp_path)
    fit = json.loads(committed("steady.json").read_text())["fit"]
    assert set(fit) == {"mu_s", "mu_d", "I0", "phi_c", "a"}


def test_transient_checks_inputs_before_any_run(tmp_path, capsys):
    from icidr_pde.cli import main

    rc = main(["dem", "transient", "--steady-json", str(tmp_path / "missing.json"), "--out", str(tmp_path)])
    assert rc == 2 and "--steady-json" in capsys.readouterr().err
    (tmp_path / "f").write_text("")
    rc = main(["dem", "transient", "--out", str(tmp_path / "f")])
    assert rc == 2 and "--out" in capsys.readouterr().err
    rc = main(["dem", "transient", "--bin-height", "4", "--out", str(tmp_path)])
    assert rc == 2 and "--bin-height" in capsys.readouterr().err
    for bad in (["--bin-height", "0"], ["--bin-height", "1.5"]):
        rc = main(["dem", "transient", *bad, "--out", str(tmp_path)])
        assert rc == 2 and "--bin-height" in capsys.readouterr().err
    for bad, name in ((["--k-n", "-1"], "--k-n"), (["--H", "nan"], "--H"), (["--t-end", "0"], "--t-end"),
                      (["--t-shear", "-1"], "--t-shear"), (["--particles", "7"], "n_particles")):
        rc = main(["dem", "transient", *bad, "--out", str(tmp_path)])
        err = capsys.readouterr().err
        assert rc == 2 and f"`{name}`" in err and "got" in err, (bad, err)
    with pytest.raises(SystemExit):
        _parse(["dem", "transient", "--seed", "-3"])
    with pytest.raises(SystemExit):
        _parse(["dem", "transient", "--fluctuations", "warm"])
    with pytest.raises(SystemExit):
        _parse(["dem", "transient", "--transient-dt-fraction", "0.5"])


def test_steady_study_rejects_bad_phi0(tmp_path):
    from icidr_pde.dem.steady import run_steady_study
    with pytest.raises(ValueError, match="phi0"):
        run_steady_study([0.95], repeats=1, cache_dir=tmp_path)
    with pytest.raises(ValueError, match="repeats"):
        run_steady_study([0.78], repeats=0, cache_dir=tmp_path)


@pytest.mark.slow
def test_continuum_initial_profiles_are_57_bin_averages():
    """The core iCIDR run, bin-averaged as the DEM, starts from (5.7)."""
    pytest.importorskip("pde")
    edges = np.linspace(0, 30, 16)
    c = transient.continuum(np.array([0.0, 0.1]), None, N=201, edges=edges)
    k = 2 * np.pi / 30
    sin_avg = (np.cos(k * edges[:-1]) - np.cos(k * edges[1:])) / (k * 2.0)
    zc = (edges[1:] + edges[:-1]) / 2
    # cell-centred finite volumes: bin averages of smooth fields to O(h^2), h = 30/201
    np.testing.assert_allclose(c["w"][0], -0.1 * sin_avg, atol=2e-3)
    np.testing.assert_allclose(c["u"][0], zc / 30 + 0.16 * sin_avg, atol=2e-3)
    np.testing.assert_allclose(c["phi"][0], 0.78, atol=1e-12)


def test_committed_audit_redraws_fig8_without_lammps(tmp_path):
    import json

    from icidr_pde.dem import analysis
    from icidr_pde.dem.paths import committed
    from icidr_pde.dem.plots import fig8_audit

    summary = json.loads(committed("audit.json").read_text())
    with np.load(committed("audit.npz")) as f:
        c = {k: f[k] for k in f.files}
    # the stored curves are the statistics of the stored fields (float32 storage)
    np.testing.assert_allclose(c["baseline_max_w"], np.abs(c["baseline_w_mean"]).max(1), rtol=1e-6)
    W1 = analysis.mode_amplitude(c["icidr_table1_w"].astype(float), c["z"], 30.0, 2.0)
    np.testing.assert_allclose(c["icidr_table1_W1"], W1, rtol=1e-5, atol=1e-8)
    assert summary["factors"]["baseline"]["repeats"] >= 30
    fig8_audit(summary, c, tmp_path / "fig.png")
    assert (tmp_path / "fig.png").stat().st_size > 10_000
