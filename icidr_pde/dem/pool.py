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
from pathlib import Path

import numpy as np

from .fit import fit_mu, fit_phi, mu_of_I
from .params import DEMParams
from .paths import committed
from .runs import Protocol
from .steady import DEFAULT_PHI0, run_steady_study

POOL_PROTOCOL = Protocol(t_shear=20.0, t_avg=50.0)
#: name -> (parameters, repeats per phi0)
CONFIGS = {
    "H20_N665": (DEMParams(n_particles=665, H=20.0), 1),
    "H40_N1335": (DEMParams(n_particles=1335, H=40.0), 1),
    "kn1e5": (DEMParams(k_n=1.0e5, eta_n=4.2 * math.sqrt(10.0)), 1),
}


def run(cache_dir, names=None, progress=True):
    """Run (or load) each configuration's sweep; dict name -> steady summary."""
    out = {}
    for name in (CONFIGS if names is None else names):
        params, repeats = CONFIGS[name]
        out[name] = run_steady_study(DEFAULT_PHI0, repeats=repeats, params=params, jobs=1,
                                     cache_dir=cache_dir, protocol=POOL_PROTOCOL, progress=progress)
        if progress:
            print(f"pool {name}: done", flush=True)
    return out


def _points(summary, ref_std=None, label=""):
    pts = []
    for pt in summary["points"]:
        r = pt["repeats"]
        if r >= 2:
            se_mu, se_I = pt["mu_std"] / math.sqrt(r), pt["I_std"] / math.sqrt(r)
        else:
            s_mu, s_I = ref_std[round(pt["phi0"], 6)]
            se_mu, se_I = s_mu * math.sqrt(2.0), s_I * math.sqrt(2.0)
        pts.append({"config": label, "phi0": pt["phi0"], "I": pt["I"], "mu": pt["mu"], "phi": pt["phi"],
                    "se_mu": se_mu, "se_I": se_I, "repeats": r, "p": pt["p"]})
    return pts


def pooled_fit(points):
    """(2.10), (2.11) fitted to pooled points (weights: their standard errors)."""
    I = np.array([p["I"] for p in points])
    mu = np.array([p["mu"] for p in points])
    phi = np.array([p["phi"] for p in points])
    fm, sm = fit_mu(I, mu, [p["se_mu"] for p in points], 1)
    fp, sp = fit_phi(I, phi, [p["se_I"] for p in points], 1)
    return {**fm, **fp}, {**sm, **sp}


def deviations(points, params):
    """Each point against a parameter set: (mu - mu(I))/se_mu and (I - (phi_c - phi)/a)/se_I."""
    out = []
    for p in points:
        dmu = (p["mu"] - mu_of_I(p["I"], params["mu_s"], params["mu_d"], params["I0"])) / p["se_mu"]
        dI = (p["I"] - (params["phi_c"] - p["phi"]) / params["a"]) / p["se_I"]
        out.append((float(dmu), float(dI)))
    return out


def cached_configs(cache_dir):
    """Names of the configurations whose every run is in the cache."""
    from . import cache
    from .steady import plan

    done = []
    for name, (params, repeats) in CONFIGS.items():
        tasks = plan(DEFAULT_PHI0, repeats, 1, params, POOL_PROTOCOL, cache_dir)
        if all(cache.load(cache_dir, cache.run_key(t[0], t[1], params, POOL_PROTOCOL)) is not None
               for t in tasks):
            done.append(name)
    return done


def summary(cache_dir):
    """Pooled fit, per-configuration deviations from the reference fit and from Table 1
    (configurations not completely cached are left out and listed)."""
    ref = json.loads(committed("steady.json").read_text())
    ref_std = {round(p["phi0"], 6): (p["mu_std"], p["I_std"]) for p in ref["points"]}
    done = cached_configs(cache_dir)
    runs = run(cache_dir, names=done, progress=False)
    points = _points(ref, ref_std, "H30_N1000_kn1e4 (reference, 30+100)")
    per = {}
    for name, s in runs.items():
        pts = _points(s, ref_std, name)
        points += pts
        dev_ref = deviations(pts, ref["fit"])
        dev_t1 = deviations(pts, ref["table1"])
        per[name] = {"points": pts,
                     "chi2_per_point_vs_reference_fit": {
                         "mu": float(np.mean([d[0] ** 2 for d in dev_ref])),
                         "I": float(np.mean([d[1] ** 2 for d in dev_ref]))},
                     "mean_deviation_vs_reference_fit_in_se": {
                         "mu": float(np.mean([d[0] for d in dev_ref])),
                         "I": float(np.mean([d[1] for d in dev_ref]))},
                     "mean_deviation_vs_table1_in_se": {
                         "mu": float(np.mean([d[0] for d in dev_t1])),
                         "I": float(np.mean([d[1] for d in dev_t1]))},
                     "params": s["params"], "repeats": s["repeats"],
                     "cpu_proxy_wall_s_per_run": s["wall_per_run_s"]}
    fit, std = pooled_fit(points)
    return {"pooled_fit": fit, "pooled_fit_std": std, "table1": ref["table1"], "reference_fit": ref["fit"],
            "reference_fit_std": ref["fit_std"], "configs": per, "n_points": len(points),
            "protocol": {"t_shear": POOL_PROTOCOL.t_shear, "t_avg": POOL_PROTOCOL.t_avg},
            "single_run_error_model": "reference run-to-run std x sqrt(100/50)",
            "not_run": [n for n in CONFIGS if n not in done],
            "all_points": points}


def main(argv=None):
    import argparse

    from .cache import default_cache_dir

    ap = argparse.ArgumentParser(prog="python -m icidr_pde.dem.pool",
                                 description="fig 1 pooled over H, N and k_n (resumable)")
    ap.add_argument("action", choices=("run", "summary"))
    ap.add_argument("--cache", default=None)
    ap.add_argument("--json", default="steady_pool.json")
    a = ap.parse_args(argv)
    cache_dir = a.cache or default_cache_dir()
    if a.action == "run":
        run(cache_dir)
    else:
        from .transient import write_json

        write_json(summary(cache_dir), Path(a.json))
        print(f"wrote {a.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
