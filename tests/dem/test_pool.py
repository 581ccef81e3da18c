"""Pooled fig 1 (icidr_pde.dem.pool) on synthetic data with known answers; no LAMMPS.

Truth: (2.10), (2.11) with Table 1 and known noise; the standard error of the mean
of white and AR(1) noise; exact duplicates of a data set; a fake run cache.
"""

import math

import numpy as np
import pytest

from icidr_pde.dem import cache, pool
from icidr_pde.dem.fit import mu_of_I

T1 = {"mu_s": 0.248, "mu_d": 0.588, "I0": 0.145, "phi_c": 0.817, "a": 0.314}
PHI0 = np.array([0.74, 0.75, 0.76, 0.77, 0.78, 0.79, 0.80, 0.81])


def synthetic_points(rng, law=T1, se_I=0.002, se_mu=0.003, config="synthetic", phi0=PHI0):
    """Points at imposed phi0: I from (2.13) and mu from (2.10), each with Gaussian noise."""
    I_true = (law["phi_c"] - phi0) / law["a"]
    I = I_true + rng.normal(0, se_I, phi0.size)
    mu = mu_of_I(I_true, law["mu_s"], law["mu_d"], law["I0"]) + rng.normal(0, se_mu, phi0.size)
    return [{"config": config, "phi0": float(f), "I": float(i), "mu": float(m), "phi": float(f),
             "se_I": se_I, "se_mu": se_mu, "repeats": 1} for f, i, m in zip(phi0, I, mu)]


def test_block_se_white_noise_and_ar1():
    rng = np.random.default_rng(0)
    n, sigma = 20000, 0.7
    white = rng.normal(0, sigma, n)
    assert pool.block_se(white, 20) == pytest.approx(sigma / math.sqrt(n), rel=0.4)
    # AR(1): the standard error of the mean is sigma_x sqrt((1 + r)/(1 - r)/n)
    r = 0.9
    x = np.empty(n)
    x[0] = 0.0
    e = rng.normal(0, 1, n)
    for i in range(1, n):
        x[i] = r * x[i - 1] + e[i]
    exact = x.std() * math.sqrt((1 + r) / (1 - r) / n)
    assert pool.block_se(x, 20) == pytest.approx(exact, rel=0.4)
    assert x.std() / math.sqrt(n) < exact / 3  # the naive error is far too small
    with pytest.raises(ValueError, match="n_blocks"):
        pool.block_se(x[:5], 10)


def test_fit_points_recovers_known_parameters():
    rng = np.random.default_rng(1)
    pts = synthetic_points(rng) + synthetic_points(rng, config="other")
    f = pool.fit_points(pts)
    for k, v in T1.items():
        assert abs(f["fit"][k] - v) < 3 * f["std"][k], k
    assert 0.2 < f["chi2_dof"]["mu"] < 3 and 0.2 < f["chi2_dof"]["phi"] < 3
    assert f["std"]["phi_c"] < 0.002 and f["std"]["mu_s"] < 0.05


def test_pooling_a_duplicate_keeps_parameters_and_shrinks_errors_by_sqrt2():
    exact = synthetic_points(np.random.default_rng(2), se_I=1e-3, se_mu=1e-3)
    for p in exact:  # noise-free: I on (2.13), mu on (2.10)
        p["I"] = (T1["phi_c"] - p["phi0"]) / T1["a"]
        p["mu"] = float(mu_of_I(p["I"], T1["mu_s"], T1["mu_d"], T1["I0"]))
    one, two = pool.fit_points(exact), pool.fit_points(exact + exact)
    for k in T1:
        assert two["fit"][k] == pytest.approx(one["fit"][k], rel=1e-6, abs=1e-9)
        assert two["std"][k] == pytest.approx(one["std"][k] / math.sqrt(2), rel=1e-3)
        assert one["fit"][k] == pytest.approx(T1[k], rel=1e-5)


def _ref_fit(rng):
    base = synthetic_points(rng, se_I=0.001, se_mu=0.0015, config="base")
    return base, pool.fit_points(base)


def test_compare_flags_a_shifted_law_and_not_the_same_law():
    rng = np.random.default_rng(3)
    base, bfit = _ref_fit(rng)
    same = pool.compare(synthetic_points(rng), base, bfit)
    assert same["I_rel_at_same_phi0"]["p_value"] > 1e-3
    assert same["mu_minus_baseline_curve"]["p_value"] > 1e-3
    shift = 0.006
    law = {**T1, "phi_c": T1["phi_c"] + shift, "mu_s": T1["mu_s"] + 0.02}
    moved = pool.compare(synthetic_points(rng, law=law), base, bfit)
    assert moved["I_rel_at_same_phi0"]["p_value"] < 1e-6
    assert moved["mu_minus_baseline_curve"]["p_value"] < 1e-6
    for row in moved["per_phi0"]:  # dI/I = shift/(phi_c - phi0) at the same phi0
        expect = shift / (T1["phi_c"] - row["phi0"])
        assert abs(row["dI_rel"] - expect) < 4 * row["dI_rel_se"] + 0.02 * expect
        assert row["dmu"] > 0


def _rows(rng, kappa, n_groups=40, repeats=3, se=0.01):
    rows = []
    for g in range(n_groups):
        for r in range(repeats):
            rows.append({"config": f"c{g % 4}", "phi0": 0.76 + 0.01 * (g // 4), "seed": r,
                         "mu": 0.4 + rng.normal(0, kappa * se), "I": 0.1 + rng.normal(0, kappa * 0.2 * se),
                         "se_mu_block": se, "se_I_block": 0.2 * se, "phi": 0.78, "p": 0.1})
    return rows


def test_error_scale_recovers_the_ratio_of_scatter_to_block_errors():
    rng = np.random.default_rng(4)
    for kappa in (1.0, 1.8):
        k = pool.error_scale(_rows(rng, kappa))
        assert k["dof"] == 80
        for q in ("mu", "I"):
            assert abs(k[q] - kappa) < 3 * k[f"{q}_uncertainty"]


def test_points_inverse_variance_means_and_order_invariance():
    rng = np.random.default_rng(5)
    rows = _rows(rng, 1.0, n_groups=4)
    kappa = {"mu": 1.5, "I": 2.0}
    pts = pool.points(rows, kappa)
    assert len(pts) == 4 and all(p["repeats"] == 3 for p in pts)
    g = [r for r in rows if r["config"] == pts[0]["config"] and round(r["phi0"], 6) == pts[0]["phi0"]]
    assert pts[0]["mu"] == pytest.approx(np.mean([r["mu"] for r in g]))
    assert pts[0]["se_mu"] == pytest.approx(1.5 * 0.01 / math.sqrt(3))
    assert pts[0]["se_I"] == pytest.approx(2.0 * 0.002 / math.sqrt(3))
    for a, b in zip(pool.points(rows[::-1], kappa), pts):
        assert (a["config"], a["phi0"]) == (b["config"], b["phi0"])
        for k in ("mu", "I", "se_mu", "se_I"):
            assert a[k] == pytest.approx(b[k], rel=1e-12)


def test_tasks_are_repeat_major_with_seeds_independent_of_the_reference_sweep():
    t = pool.tasks(["H20_N665", "kn1e6"], {"H20_N665": 2, "kn1e6": 1})
    names = [x[0] for x in t]
    n20, n6 = len(pool.CONFIGS["H20_N665"].phi0s), len(pool.CONFIGS["kn1e6"].phi0s)
    assert names == ["H20_N665"] * n20 + ["kn1e6"] * n6 + ["H20_N665"] * n20
    ref_seeds = {cache.run_seed(1, r, f) for r in range(10) for f in (0.76, 0.77, 0.78, 0.79, 0.80)}
    assert not ref_seeds & {x[2] for x in pool.tasks()}
    with pytest.raises(ValueError, match="configs"):
        pool.tasks(["H99"])


def _fake_run(phi0, seed, params, protocol):
    """A cached-run dict with the fields pool reads; p from (2.13) at Table 1."""
    rng = np.random.default_rng(seed)
    I = (T1["phi_c"] - phi0) / T1["a"]
    p = (params.shear_rate / I) ** 2
    n = int(round(protocol.t_avg / protocol.sample_every))
    ts_p = p * (1 + 0.1 * rng.normal(size=n + 4))
    ts_mu = mu_of_I(I, T1["mu_s"], T1["mu_d"], T1["I0"]) + 0.01 * rng.normal(size=n + 4)
    return {"phi0": phi0, "seed": seed, "I": I, "mu": float(ts_mu[4:].mean()), "p": p, "phi_mean": phi0,
            "ts_t": np.arange(n + 4) * 0.5, "ts_p": ts_p, "ts_mu": ts_mu,
            "n_particles": params.n_particles, "cpu_total": 1.0}


def test_run_is_resumable_and_summary_uses_what_is_cached(tmp_path, monkeypatch):
    calls = []

    def fake(phi0, seed, params, protocol):
        if len(calls) == 3 and not any(c == "failed" for c in calls):
            calls.append("failed")
            raise RuntimeError("interrupted")
        calls.append((phi0, seed))
        return _fake_run(phi0, seed, params, protocol)

    monkeypatch.setattr(pool, "run_cell", fake)
    names = ["H20_N665"]
    with pytest.raises(RuntimeError, match="interrupted"):
        pool.run(tmp_path, names, {"H20_N665": 1}, progress=False)
    assert len(list(tmp_path.glob("*.npz"))) == 3  # each run cached as it finished
    pool.run(tmp_path, names, {"H20_N665": 1}, progress=False)
    done = [c for c in calls if c != "failed"]
    assert len(done) == 5 and len(set(done)) == 5  # the rerun did only the two missing runs
    pool.run(tmp_path, names, {"H20_N665": 1}, progress=False)
    assert len([c for c in calls if c != "failed"]) == 5  # nothing left to do

    s = pool.summary(tmp_path)
    assert list(s["configs"]) == ["H20_N665"] and "kn1e6" in s["not_run"]
    cfg = s["configs"]["H20_N665"]
    assert cfg["runs"] == 5 and cfg["phi0_missing"] == []
    n_ref = len([p for p in s["points"] if p["config"] == pool.REFERENCE])
    assert len(s["points"]) == n_ref + 5 == s["pooled_fit"]["n_points"]
    assert s["cpu_s_total"] == pytest.approx(5.0)
    # fake runs lie on Table 1: the configuration's fitted Phi(I) is Table 1's
    assert cfg["fit"]["fit"]["phi_c"] == pytest.approx(T1["phi_c"], abs=1e-9)
    assert cfg["fit"]["fit"]["a"] == pytest.approx(T1["a"], rel=1e-9)


def test_run_order_holds_every_configured_run_once():
    ordered = pool.ordered_tasks()
    assert len(ordered) == len(set(ordered)) and set(pool.tasks()) <= set(ordered)
    extra = set(ordered) - set(pool.tasks())  # only extra repeats of configured runs
    assert all(t[0] in pool.CONFIGS and t[1] in pool.CONFIGS[t[0]].phi0s for t in extra)


def test_cli_pool_summary_writes_json_and_figure_and_refuses_unknown_configs(tmp_path, monkeypatch, capsys):
    from icidr_pde.cli import main

    monkeypatch.setattr(pool, "run_cell", _fake_run)
    cache_dir = tmp_path / "cache"
    pool.run(cache_dir, ["H40_N1335"], {"H40_N1335": 1}, progress=False)
    out = tmp_path / "out"
    assert main(["dem", "pool", "summary", "--cache", str(cache_dir), "--out", str(out)]) == 0
    assert (out / "steady_pool.json").is_file() and (out / "fig1_dem.png").is_file()
    assert "H40_N1335" in capsys.readouterr().out
    assert main(["dem", "pool", "tables", "--out", str(out)]) == 0  # the tables of docs/dem.md, from that file
    assert "| H40_N1335 |" in capsys.readouterr().out
    assert main(["dem", "pool", "tables", "--out", str(tmp_path / "none")]) == 2
    assert main(["dem", "pool", "run", "H99", "--cache", str(cache_dir)]) == 2
    assert "H99" in capsys.readouterr().err
