"""Steady-state sweep over phi0 (appendix C, figure 1): mu(I), Phi(I) and fits.

Each (phi0, repeat) is an independent LAMMPS run, cached as one .npz; the
runs at phi0 = 0.78 also carry the (5.7) transient used by figure 8.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np

from ..outputs import write_json
from ..rheology import TABLE1
from ..studies.parallel import run_cases
from . import cache
from .fit import fit_mu, fit_phi, mu_of_I
from .params import DEMParams, check_phi0
from .runs import Protocol, run_cell

TRANSIENT_PHI0 = 0.78
DEFAULT_PHI0 = (0.76, 0.77, 0.78, 0.79, 0.80)


def _task(args):
    """One (phi0, repeat) of the study (a task): its result from the cache, or run and cached."""
    phi0, seed, params, protocol, cache_dir = args
    key = cache.run_key(phi0, seed, params, protocol)
    res = cache.load(cache_dir, key)
    if res is not None:
        return res
    res = run_cell(phi0, seed, params, protocol)
    cache.save(cache_dir, key, res)
    return res


def plan(phi0s, repeats, base_seed, params, protocol, cache_dir):
    """Task list ordered repeat-major, so an interrupted study has whole repeats."""
    tasks = []
    for r in range(repeats):
        for phi0 in phi0s:
            tasks.append((phi0, cache.run_seed(base_seed, r, phi0), params, protocol, str(cache_dir)))
    return tasks


def execute(tasks, jobs=2, progress=True, client=None):
    """Results of all tasks (run, or loaded from the cache), in their order.

    The runs are independent LAMMPS processes: `jobs` worker processes of this machine, or
    tasks of the dask `client` (neither: one after the other here). Each run is cached as it
    finishes, so an interrupted study resumes; on a cluster the cache folder must be one that
    every worker sees.
    """
    return list(run_cases(_task, tasks, jobs, progress, desc="DEM runs", client=client, init_here=False))


def summarize(results, table1=None) -> dict:
    """Points per phi0 (mean and std over repeats), fits of (2.10), (2.11)."""
    by_phi = {}
    for r in results:
        by_phi.setdefault(round(float(r["phi0"]), 6), []).append(r)
    points = []
    for phi0 in sorted(by_phi):
        rs = by_phi[phi0]
        I = np.array([r["I"] for r in rs])
        mu = np.array([r["mu"] for r in rs])
        p = np.array([r["p"] for r in rs])
        phi = np.array([r["phi_mean"] for r in rs])
        ddof = 1 if len(rs) > 1 else 0
        points.append({
            "phi0": phi0, "I": float(I.mean()), "I_std": float(I.std(ddof=ddof)),
            "mu": float(mu.mean()), "mu_std": float(mu.std(ddof=ddof)),
            "phi": float(phi.mean()), "p": float(p.mean()), "p_std": float(p.std(ddof=ddof)),
            "shear_rate": float(np.mean([r["shear_rate"] for r in rs])),
            "repeats": len(rs),
        })
    n_rep = min(pt["repeats"] for pt in points)
    I = np.array([pt["I"] for pt in points])
    out = {"points": points, "repeats": n_rep}
    if len(points) >= 3:
        fm, sm, corr = fit_mu(I, [pt["mu"] for pt in points], [pt["mu_std"] for pt in points],
                              n_rep, return_corr=True)
        fp, sp = fit_phi(I, [pt["phi"] for pt in points], [pt["I_std"] for pt in points], n_rep)
        out["fit"] = {**fm, **fp}
        # non-finite uncertainties (e.g. 3 points for 3 parameters) -> null in JSON
        out["fit_std"] = {k: (v if np.isfinite(v) else None) for k, v in {**sm, **sp}.items()}
        out["fit_corr_mu_s_mu_d_I0"] = corr
        if table1 is not None:
            # how far apart the two parameter sets are where there are data
            Ig = np.linspace(I.min(), I.max(), 200)
            t = table1
            out["max_curve_difference_on_data_range"] = {
                "mu": float(np.max(np.abs(mu_of_I(Ig, fm["mu_s"], fm["mu_d"], fm["I0"])
                                          - mu_of_I(Ig, t["mu_s"], t["mu_d"], t["I0"])))),
                "phi": float(np.max(np.abs((fp["phi_c"] - fp["a"] * Ig) - (t["phi_c"] - t["a"] * Ig)))),
                "I_range": [float(I.min()), float(I.max())]}
    if table1 is not None:
        out["table1"] = table1
    out["wall_per_run_s"] = float(np.mean([r["wall_total"] for r in results]))
    out["dt"] = float(results[0]["dt"])
    out["n_particles"] = int(results[0]["n_particles"])
    return out


def table1_dict():
    return dict(TABLE1)


def run_steady_study(phi0s=DEFAULT_PHI0, repeats=10, n_particles=1000, base_seed=1,
                     jobs=2, cache_dir=cache.DEFAULT_CACHE, protocol=None, params=None,
                     json_path=None, progress=True, client=None) -> dict:
    """The full figure-1 study; returns (and optionally writes) the JSON summary.

    The runs go to `jobs` worker processes or to the dask `client` (:func:`execute`)."""
    phi0s = [check_phi0(p) for p in phi0s]
    if len(phi0s) < 1:
        raise ValueError("`phi0s` must hold at least one packing fraction")
    if not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"`repeats` must be an integer >= 1; got {repeats!r}")
    params = params or DEMParams(n_particles=n_particles)
    protocol = protocol or Protocol()
    tasks = plan(phi0s, repeats, base_seed, params, protocol, cache_dir)
    results = execute(tasks, jobs=jobs, progress=progress, client=client)
    summary = summarize(results, table1_dict())
    summary["wall_total_s"] = float(sum(r["wall_total"] for r in results))
    summary.update(params=asdict(params), protocol=asdict(protocol), base_seed=base_seed)
    if json_path:
        write_json(summary, json_path)
    return summary
