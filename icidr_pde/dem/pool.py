"""Figure 1 as the paper pools it: steady runs at other cell heights H (and so
particle counts N at the same L) and normal stiffness k_n, fitted together
with the reference sweep (N = 1000, H = 30, k_n = 1e4; data/dem/steady.json).

k_n = 1e5 keeps the restitution e = 0.9 by scaling eta_n with sqrt(k_n) (the
paper states e = 0.9 and that the results do not depend on the dissipation);
its time step is t_c/50 of the stiffer contact (3.2 times more steps).

Pool runs use a shorter protocol (20 time units of shear, 50 of averaging)
than the reference sweep (30 + 100).  Where a configuration has a single run
per phi0 its scatter is estimated from the reference sweep's run-to-run
standard deviation scaled by sqrt(100/50) for the shorter average (stated in
the summary).  Resumable: every run is cached.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from . import cache
from .fit import fit_mu, fit_phi, mu_of_I
from .params import DEMParams
from .paths import committed
from .runs import Protocol, run_cell
from .steady import DEFAULT_PHI0

POOL_PROTOCOL = Protocol(t_shear=20.0, t_avg=50.0)
#: base seed of the pool; the reference sweep used 1, whose placements at N = 1000
#: (same seed, N and L) the k_n and control runs would otherwise repeat
POOL_SEED = 2


@dataclass(frozen=True)
class PoolConfig:
    """One configuration of the pool: cell and contact law, repeats per phi0,
    the phi0 values (in running order) and what it varies against the reference."""

    params: DEMParams
    repeats: int
    phi0s: tuple
    varies: str


#: name -> configuration, in running order (whole repeats of every configuration first)
CONFIGS = {
    "H30_N1000": PoolConfig(DEMParams(), 3, DEFAULT_PHI0,
                            "control: the reference cell with the pool's shorter protocol"),
    "H20_N665": PoolConfig(DEMParams(n_particles=665, H=20.0), 3, DEFAULT_PHI0, "height (and N at the same L)"),
    "H40_N1335": PoolConfig(DEMParams(n_particles=1335, H=40.0), 3, DEFAULT_PHI0, "height (and N at the same L)"),
    "H30_N500": PoolConfig(DEMParams(n_particles=500), 3, DEFAULT_PHI0, "particle count at the same H (L halved)"),
    "kn1e5": PoolConfig(DEMParams(k_n=1.0e5, eta_n=4.2 * math.sqrt(10.0)), 3, DEFAULT_PHI0, "stiffness"),
    "kn1e6": PoolConfig(DEMParams(k_n=1.0e6, eta_n=4.2 * math.sqrt(100.0)), 1,
                        (0.80, 0.76, 0.78, 0.79, 0.77), "stiffness"),
}


_CHEAP = ("H30_N1000", "H20_N665", "H40_N1335", "H30_N500")
#: default running order, (configuration, repeat index[, phi0 values]): the cheap
#: configurations' first two repeats (which also check the error model), then the stiff
#: contacts, where phi0 = 0.80 (the largest p/k_n) is repeated before the other phi0 values
RUN_ORDER = ([(c, 0) for c in _CHEAP] + [(c, 1) for c in _CHEAP] + [("kn1e5", 0)]
             + [("kn1e6", 0, (0.80, 0.76)), ("kn1e6", 1, (0.80,)), ("kn1e5", 1, (0.80,)), ("kn1e5", 2, (0.80,)),
                ("kn1e6", 0)]
             + [(c, 2) for c in _CHEAP] + [("kn1e5", 1), ("kn1e5", 2)])


def tasks(names=None, repeats=None):
    """(name, phi0, seed, params) of every run, repeat-major across configurations, so
    an interrupted pool holds whole repeats of every configuration first.  ``repeats``
    overrides the per-configuration number (name -> int)."""
    names = list(CONFIGS) if names is None else list(names)
    unknown = [n for n in names if n not in CONFIGS]
    if unknown:
        raise ValueError(f"`configs` must be among {list(CONFIGS)}; got {unknown}")
    reps = {n: (repeats or {}).get(n, CONFIGS[n].repeats) for n in names}
    out = []
    for r in range(max(reps.values(), default=0)):
        for n in names:
            if r < reps[n]:
                for phi0 in CONFIGS[n].phi0s:
                    out.append((n, phi0, cache.run_seed(POOL_SEED, r, phi0), CONFIGS[n].params))
    return out


def run_key(phi0, seed, params):
    return cache.run_key(phi0, seed, params, POOL_PROTOCOL)


def ordered_tasks(order=RUN_ORDER):
    """Tasks of :func:`tasks` for a list of (configuration, repeat index[, phi0 values])
    stages, each run once, in order."""
    out = []
    for name, r, *phi0s in order:
        if name not in CONFIGS:
            raise ValueError(f"`configs` must be among {list(CONFIGS)}; got {name!r}")
        for phi0 in (phi0s[0] if phi0s else CONFIGS[name].phi0s):
            t = (name, phi0, cache.run_seed(POOL_SEED, r, phi0), CONFIGS[name].params)
            if t not in out:
                out.append(t)
    return out


def run(cache_dir, names=None, repeats=None, progress=True):
    """Run every missing pool run (one LAMMPS process at a time), each cached as it
    finishes; an interrupted pool restarts where it stopped.  Without ``names`` and
    ``repeats`` the runs follow :data:`RUN_ORDER`."""
    todo = ordered_tasks() if names is None and repeats is None else tasks(names, repeats)
    for i, (name, phi0, seed, params) in enumerate(todo):
        key = run_key(phi0, seed, params)
        if cache.load(cache_dir, key) is not None:
            continue
        res = run_cell(phi0, seed, params, POOL_PROTOCOL)
        res["config"] = name
        cache.save(cache_dir, key, res)
        if progress:
            print(f"[{i + 1}/{len(todo)}] {name} phi0={phi0:.2f} seed={seed}: I={res['I']:.4f} "
                  f"mu={res['mu']:.4f} cpu {res['cpu_total']:.1f} s", flush=True)


# ------------------------------------------------------------------ analysis (no LAMMPS)
#: length (time units) of the blocks of the within-run standard error
BLOCK = 5.0


def block_se(series, n_blocks):
    """Standard error of the mean of a correlated time series from ``n_blocks``
    non-overlapping block means (the trailing remainder is dropped)."""
    x = np.asarray(series, float)
    if not isinstance(n_blocks, (int, np.integer)) or n_blocks < 2 or x.size < n_blocks:
        raise ValueError(f"`n_blocks` must be an integer in [2, {x.size}]; got {n_blocks!r}")
    m = x.size // n_blocks
    b = x[: m * n_blocks].reshape(n_blocks, m).mean(1)
    return float(b.std(ddof=1) / math.sqrt(n_blocks))


def run_row(res, config, block=BLOCK):
    """One cached run as a table row: I, mu, phi, p and their within-run standard
    errors (block means of the sampled cell-mean p and mu; se_I from I ~ p^-1/2);
    ``p_drift`` = ln(mean p of the second half of the window / first half)."""
    t = np.asarray(res["ts_t"], float)
    avg = slice(t.size - int(round(POOL_PROTOCOL.t_avg / POOL_PROTOCOL.sample_every)), None)  # the averaging samples
    n_blocks = max(2, int(round(POOL_PROTOCOL.t_avg / block)))
    p_ts, mu_ts = np.asarray(res["ts_p"])[avg], np.asarray(res["ts_mu"])[avg]
    p, I = float(res["p"]), float(res["I"])
    se_p = block_se(p_ts, n_blocks)
    return {"config": config, "phi0": float(res["phi0"]), "seed": int(res["seed"]), "I": I,
            "mu": float(res["mu"]), "phi": float(res["phi_mean"]), "p": p,
            "se_mu_block": block_se(mu_ts, n_blocks), "se_I_block": 0.5 * I * se_p / p,
            "p_drift": float(np.log(p_ts[p_ts.size // 2:].mean() / p_ts[: p_ts.size // 2].mean())),
            "n_particles": int(res["n_particles"]), "cpu_s": float(res["cpu_total"])}


def load_runs(cache_dir, names=None, max_repeats=20):
    """Rows of every cached pool run (up to ``max_repeats`` per phi0), no LAMMPS."""
    names = list(CONFIGS) if names is None else list(names)
    rows = []
    for name, phi0, seed, params in tasks(names, {n: max_repeats for n in names}):
        res = cache.load(cache_dir, run_key(phi0, seed, params))
        if res is not None:
            rows.append(run_row(res, name))
    return rows


def error_scale(rows):
    """Run-to-run scatter against the within-run standard errors: for every
    (config, phi0) with >= 2 runs, sum (x_i - mean)^2 / se_i^2 ~ chi^2(r - 1) if the
    block errors are right.  Returns {"mu": kappa, "I": kappa, "dof": n} with kappa^2
    the pooled ratio (1 where there is no repeat)."""
    groups = {}
    for r in rows:
        groups.setdefault((r["config"], round(r["phi0"], 6)), []).append(r)
    out, dof = {}, sum(len(g) - 1 for g in groups.values())
    for q in ("mu", "I"):
        chi2 = 0.0
        for g in groups.values():
            if len(g) >= 2:
                x = np.array([r[q] for r in g])
                w = 1.0 / np.array([r[f"se_{q}_block"] for r in g]) ** 2
                xm = np.sum(w * x) / np.sum(w)
                chi2 += float(np.sum(w * (x - xm) ** 2))
        out[q] = math.sqrt(chi2 / dof) if dof else 1.0
        out[f"{q}_uncertainty"] = out[q] / math.sqrt(2 * dof) if dof else None
    out["dof"] = dof
    return out


def points(rows, kappa):
    """Per (config, phi0): inverse-variance means of the runs, standard errors from the
    block errors scaled by ``kappa`` (:func:`error_scale`), and the observed spread."""
    groups = {}
    for r in rows:
        groups.setdefault((r["config"], round(r["phi0"], 6)), []).append(r)
    out = []
    for (config, phi0), g in sorted(groups.items()):
        pt = {"config": config, "phi0": phi0, "repeats": len(g), "seeds": [r["seed"] for r in g]}
        for q in ("mu", "I"):
            x = np.array([r[q] for r in g])
            s = kappa[q] * np.array([r[f"se_{q}_block"] for r in g])
            w = 1.0 / s**2
            pt[q] = float(np.sum(w * x) / np.sum(w))
            pt[f"se_{q}"] = float(1.0 / math.sqrt(np.sum(w)))
            pt[f"{q}_std_runs"] = float(x.std(ddof=1)) if len(g) > 1 else None
        pt["phi"] = float(np.mean([r["phi"] for r in g]))
        pt["p"] = float(np.mean([r["p"] for r in g]))
        out.append(pt)
    return out


def reference_points(ref):
    """The committed reference sweep (N = 1000, H = 30, k_n = 1e4, 30 + 100 time units,
    10 repeats) as pool points: standard errors std/sqrt(repeats)."""
    return [{"config": REFERENCE, "phi0": p["phi0"], "repeats": p["repeats"], "I": p["I"], "mu": p["mu"],
             "se_I": p["I_std"] / math.sqrt(p["repeats"]), "se_mu": p["mu_std"] / math.sqrt(p["repeats"]),
             "I_std_runs": p["I_std"], "mu_std_runs": p["mu_std"], "phi": p["phi"], "p": p["p"]}
            for p in ref["points"]]


REFERENCE = "reference"


def _dmu_dI(I, f):
    return (f["mu_d"] - f["mu_s"]) * f["I0"] / (I + f["I0"]) ** 2


def fit_points(pts, slope_from=None):
    """(2.10), (2.11) fitted to points with known standard errors.  The mu fit uses the
    effective variance se_mu^2 + (mu'(I) se_I)^2 (I is measured too; mu' from
    ``slope_from`` or a first fit).  Parameter errors: absolute, multiplied by
    sqrt(chi^2/dof) where that exceeds 1.  Returns dict fit, std, chi2_dof, cov_mu."""
    I = np.array([p["I"] for p in pts])
    mu = np.array([p["mu"] for p in pts])
    phi = np.array([p["phi"] for p in pts])
    se_mu = np.array([p["se_mu"] for p in pts])
    se_I = np.array([p["se_I"] for p in pts])
    out = {"n_points": len(pts)}
    if len({round(p["phi0"], 6) for p in pts}) < 3:  # a line through 2 points has no error
        return out
    fp, sp = fit_phi(I, phi, se_I, 1, absolute_sigma=True)
    res_I = (I - (fp["phi_c"] - phi) / fp["a"]) / se_I
    dof_phi = len(pts) - 2
    chi_phi = float(np.sum(res_I**2) / dof_phi) if dof_phi > 0 else None
    fit, std = dict(fp), dict(sp)
    if chi_phi is not None and chi_phi > 1:
        std = {k: v * math.sqrt(chi_phi) for k, v in std.items()}
    out["chi2_dof"] = {"phi": chi_phi}
    if len(pts) >= 4:
        f0 = slope_from or fit_mu(I, mu, se_mu, 1)[0]
        s_eff = np.hypot(se_mu, _dmu_dI(I, f0) * se_I)
        fm, sm, corr = fit_mu(I, mu, s_eff, 1, return_corr=True, absolute_sigma=True)
        res = (mu - mu_of_I(I, fm["mu_s"], fm["mu_d"], fm["I0"])) / s_eff
        chi_mu = float(np.sum(res**2) / (len(pts) - 3))
        scale = math.sqrt(max(chi_mu, 1.0))
        fit.update(fm)
        std.update({k: v * scale for k, v in sm.items()})
        sd = np.array([sm[k] for k in ("mu_s", "mu_d", "I0")]) * scale
        out["cov_mu"] = (np.array(corr) * np.outer(sd, sd)).tolist()
        out["corr_mu"] = corr
        out["chi2_dof"]["mu"] = chi_mu
    out.update(fit=fit, std=std)
    return out


def _chi2_test(d, s):
    from scipy.stats import chi2

    d, s = np.asarray(d, float), np.asarray(s, float)
    c = float(np.sum((d / s) ** 2))
    w = 1.0 / s**2
    return {"chi2": c, "dof": int(d.size), "p_value": float(chi2.sf(c, d.size)),
            "weighted_mean": float(np.sum(w * d) / np.sum(w)), "weighted_mean_se": float(1 / math.sqrt(np.sum(w)))}


def compare(pts, base_pts, base_fit):
    """Does a configuration differ from a baseline?  Model-free in Phi: I at the same
    phi0 (imposed), relative difference; in mu: mu minus the baseline's (2.10) at the
    configuration's own I, with the baseline curve's covariance and mu'(I) se_I in the
    error.  chi^2 over the common phi0 values, its p-value and the weighted mean."""
    by = {round(p["phi0"], 6): p for p in base_pts}
    f, cov = base_fit["fit"], np.array(base_fit["cov_mu"])
    dI, sI, dmu, smu, rows = [], [], [], [], []
    for p in pts:
        b = by.get(round(p["phi0"], 6))
        if b is None:
            continue
        dI.append((p["I"] - b["I"]) / b["I"])
        sI.append(math.hypot(p["se_I"], b["se_I"] * p["I"] / b["I"]) / b["I"])
        I = p["I"]
        # gradient of (2.10) in (mu_s, mu_d, I0) at I
        x = I / (I + f["I0"])
        g = np.array([1 - x, x, -(f["mu_d"] - f["mu_s"]) * I / (I + f["I0"]) ** 2])
        dmu.append(p["mu"] - mu_of_I(I, f["mu_s"], f["mu_d"], f["I0"]))
        smu.append(math.sqrt(p["se_mu"] ** 2 + (_dmu_dI(I, f) * p["se_I"]) ** 2 + g @ cov @ g))
        rows.append({"phi0": p["phi0"], "dI_rel": dI[-1], "dI_rel_se": sI[-1], "dmu": float(dmu[-1]),
                     "dmu_se": smu[-1]})
    if not rows:
        return None
    return {"I_rel_at_same_phi0": _chi2_test(dI, sI), "mu_minus_baseline_curve": _chi2_test(dmu, smu),
            "per_phi0": rows}


def parameter_differences(a, b):
    """(a - b)/sqrt(se_a^2 + se_b^2) for each parameter both fits determine."""
    out = {}
    for k, v in a.get("fit", {}).items():
        if k in b.get("fit", {}):
            s = math.hypot(a["std"][k], b["std"][k])
            out[k] = {"difference": v - b["fit"][k], "se": s, "in_se": (v - b["fit"][k]) / s}
    return out


def _mean_se(x):
    x = np.asarray(x, float)
    return {"mean": float(x.mean()), "se": float(x.std(ddof=1) / math.sqrt(x.size)) if x.size > 1 else None,
            "n": int(x.size)}


def summary(cache_dir, names=None):
    """Pooled fig 1 from the cached pool runs and the committed reference sweep:
    per-run rows, points, the error model check, fits per configuration and pooled,
    and each configuration against the reference (and the control)."""
    ref = json.loads(committed("steady.json").read_text())
    rows = load_runs(cache_dir, names)
    kappa = error_scale(rows)
    pool_pts = points(rows, kappa)
    ref_pts = reference_points(ref)
    ref_fit = fit_points(ref_pts)
    control = [p for p in pool_pts if p["config"] == "H30_N1000"]
    control_fit = fit_points(control) if len(control) >= 4 else None
    configs = {}
    for name, cfg in CONFIGS.items():
        pts = [p for p in pool_pts if p["config"] == name]
        if not pts:
            continue
        f = fit_points(pts, slope_from=ref_fit["fit"])
        done = {round(p["phi0"], 6) for p in pts}
        configs[name] = {
            "varies": cfg.varies, "params": asdict(cfg.params),
            "runs": sum(p["repeats"] for p in pts),
            "repeats_per_phi0": {f"{p['phi0']:.2f}": p["repeats"] for p in pts},
            "phi0_missing": [x for x in cfg.phi0s if round(x, 6) not in done],
            "fit": f, "parameters_minus_reference_fit": parameter_differences(f, ref_fit),
            "vs_reference": compare(pts, ref_pts, ref_fit),
            "vs_control": (compare(pts, control, control_fit) if control_fit and name != "H30_N1000" else None),
            "p_drift": _mean_se([r["p_drift"] for r in rows if r["config"] == name]),
            "cpu_s": sum(r["cpu_s"] for r in rows if r["config"] == name)}
    all_pts = ref_pts + pool_pts
    pooled = fit_points(all_pts, slope_from=ref_fit["fit"])
    t1 = ref["table1"]
    pooled["minus_table1_in_se"] = {k: (v - t1[k]) / pooled["std"][k] for k, v in pooled["fit"].items()}
    return {
        "what": "fig 1 pooled over the cell height H, particle count N and normal stiffness k_n (appendix C)",
        "paper_pool": "fig 1 of the paper pools runs with differing k_n, H and N (numbers not given); "
                      "phi0 = 0.76-0.80, 10 repeats per run",
        "protocol": {"t_shear": POOL_PROTOCOL.t_shear, "t_avg": POOL_PROTOCOL.t_avg,
                     "sample_every": POOL_PROTOCOL.sample_every, "pool_seed": POOL_SEED,
                     "reference": "30 + 100 time units, 10 repeats, seed 1 (data/dem/steady.json)"},
        "error_model": {"block_time_units": BLOCK, "kappa": kappa,
                        "description": "point standard errors = within-run block errors x kappa; kappa^2 = "
                                       "pooled chi^2/dof of the run-to-run scatter against the block errors"},
        "table1": t1, "reference_fit": ref_fit, "control_fit": control_fit, "pooled_fit": pooled,
        "configs": configs,
        "not_run": [n for n in CONFIGS if n not in configs],
        "p_drift_all_runs": _mean_se([r["p_drift"] for r in rows]) if rows else None,
        "points": all_pts, "runs": rows,
        "cpu_s_total": float(sum(r["cpu_s"] for r in rows)),
    }


def _pm(v, s, nd=3):
    if s is None or not math.isfinite(s):
        return f"{v:.{nd}f}"
    if s > abs(v):  # the data do not determine it (degenerate (2.10) parameters)
        return "undetermined"
    return f"{v:.{nd}f} ± {s:.{nd}f}"


PARAM_DIGITS = {"mu_s": 3, "mu_d": 3, "I0": 3, "phi_c": 4, "a": 3}


def markdown(s):
    """The pooled-fit tables of docs/dem.md from a :func:`summary` dict."""
    keys = list(PARAM_DIGITS)
    lines = ["| data | runs | " + " | ".join(keys) + " | chi²/dof mu, I |", "|---" * (len(keys) + 3) + "|"]

    def row(label, f, runs):
        if "fit" not in f:
            return
        cells = [_pm(f["fit"][k], f["std"].get(k), PARAM_DIGITS[k]) if k in f["fit"] else "–" for k in keys]
        c = f.get("chi2_dof", {})
        chi = ", ".join(f"{c[q]:.1f}" if c.get(q) is not None else "–" for q in ("mu", "phi"))
        lines.append(f"| {label} | {runs} | " + " | ".join(cells) + f" | {chi} |")

    lines.append("| Table 1 | – | " + " | ".join(str(s["table1"][k]) for k in keys) + " | |")
    row("pooled (all)", s["pooled_fit"], sum(c["runs"] for c in s["configs"].values()) + 50)
    row("reference sweep", s["reference_fit"], 50)
    for name, c in s["configs"].items():
        row(name, c["fit"], c["runs"])
    lines += ["", "| configuration | varies | I − I_ref at the same phi0 (relative, weighted mean) "
              "| χ²/dof, p | mu − reference (2.10) at its own I | χ²/dof, p |", "|---|---|---|---|---|---|"]
    for name, c in s["configs"].items():
        v = c["vs_reference"]
        if not v:
            continue
        a, b = v["I_rel_at_same_phi0"], v["mu_minus_baseline_curve"]
        lines.append(f"| {name} | {c['varies']} | {100 * a['weighted_mean']:+.1f} ± {100 * a['weighted_mean_se']:.1f} % "
                     f"| {a['chi2'] / a['dof']:.1f}, {a['p_value']:.2g} | {b['weighted_mean']:+.4f} ± "
                     f"{b['weighted_mean_se']:.4f} | {b['chi2'] / b['dof']:.1f}, {b['p_value']:.2g} |")
    ctl = [(n, c["vs_control"]) for n, c in s["configs"].items() if c.get("vs_control")]
    if ctl:
        lines += ["", "| configuration against the control (same protocol) | I − I_control (relative) | χ²/dof, p "
                  "| mu − control (2.10) | χ²/dof, p |", "|---|---|---|---|---|"]
        for name, v in ctl:
            a, b = v["I_rel_at_same_phi0"], v["mu_minus_baseline_curve"]
            lines.append(f"| {name} | {100 * a['weighted_mean']:+.1f} ± {100 * a['weighted_mean_se']:.1f} % "
                         f"| {a['chi2'] / a['dof']:.1f}, {a['p_value']:.2g} | {b['weighted_mean']:+.4f} ± "
                         f"{b['weighted_mean_se']:.4f} | {b['chi2'] / b['dof']:.1f}, {b['p_value']:.2g} |")
    return "\n".join(lines)
