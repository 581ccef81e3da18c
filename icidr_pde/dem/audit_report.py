"""Summaries of the protocol audit (issue 16): factor table, ensemble size,
definitions of u and bins, continuum sensitivity, local rheology in the transient.

Reads the cached DEM members (no LAMMPS), runs the continuum (iCIDR via
``icidr_pde.run``, cached), and writes a JSON summary, a small npz with the
curves of the figure, and the figure.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np

from ..outputs import replacing, write_atomically

from . import analysis as A
from . import audit

FIELDS = ("phi", "u", "w")
#: continuum grid cells; the secondary peak is grid converged here (checked in the report)
N_CONT = 201


# ------------------------------------------------------------------ continuum
def continuum_raw(material, times, cache_dir, H=30.0, phi0=0.78, a=0.16, b=0.1, N=N_CONT):
    """iCIDR (5.7) run at ``times`` (fields on the grid), cached by parameters."""
    from icidr_pde import run
    from icidr_pde.rheology import Material

    material = material or Material()
    times = np.round(np.asarray(times, float), 10)
    key = hashlib.sha1(repr((material.to_dict(), times.tolist(), H, phi0, a, b, N)).encode()).hexdigest()[:10]
    path = Path(cache_dir) / f"continuum_{key}.npz"
    if path.exists():
        with np.load(path) as f:
            return {k: f[k] for k in f.files}
    c0 = time.process_time()
    res = run(rheology="icidr", scene="sine", N=N, t_end=float(times.max()), times=list(times),
              material=material, phi0=phi0, a=a, b=b, H=H)
    if res.blew_up:
        raise RuntimeError(f"continuum run failed at t = {res.t_final}: {res.reason}")
    out = {"z": np.asarray(res.z), "times": np.asarray(res.times), "cpu_s": time.process_time() - c0,
           **{f: np.asarray(getattr(res, f)) for f in FIELDS}}
    Path(cache_dir).mkdir(parents=True, exist_ok=True)
    with replacing(path) as tmp:
        np.savez_compressed(tmp, **out)
    return out


def binned(raw, H, bin_height):
    """Continuum fields averaged over DEM bins (cell-centred grid, exact per cell overlap)."""
    from .transient import bin_average

    edges = np.linspace(0.0, H, int(round(H / bin_height)) + 1)
    return {f: np.array([bin_average(raw["z"], row, edges, H) for row in raw[f]]) for f in FIELDS}


# ------------------------------------------------------------------ DEM side
def _mean_se(S, idx=None):
    idx = np.arange(S["w"].shape[0]) if idx is None else idx
    R = len(idx)
    mean = {f: S[f][idx].mean(0) for f in FIELDS}
    se = {f: S[f][idx].std(0, ddof=1) / np.sqrt(R) for f in FIELDS}
    mean.update(times=S["times"], V0=S["V0"])
    return mean, se


def factor_summary(S, cont_t1, cont_fit, phi0, n_boot=300):
    """Peak statistics (bootstrap over members) and errors against iCIDR."""
    t, z, H, hb = S["times"], S["z"], S["H"], S["bin_height"]

    def stat(idx):
        m, _ = _mean_se(S, idx)
        return A.peak_stats(m["w"], t, z, H, hb)

    bs = A.bootstrap(list(range(S["w"].shape[0])), stat, n_boot=n_boot)
    mean, se = _mean_se(S)
    out = {"repeats": int(S["w"].shape[0]),
           "peak": {k: {"value": v, "se": s} for k, (v, s) in bs.items()}}
    for name, cont in (("table1", cont_t1), ("fitted", cont_fit)):
        e = A.errors(mean, cont, phi0, S["V0"], H, z, se)
        out[f"errors_{name}"] = {
            "E_max": float(e["E"].max()), "E_mean": float(e["E"].mean()),
            **{f"E_{f}_max": float(e[f"E_{f}"].max()) for f in FIELDS},
            **{f"E_{f}_floor_mean": float(e[f"E_{f}_floor"].mean()) for f in FIELDS},
            **{f"R_{f}": e[f"R_{f}"] for f in FIELDS},
            **{f"R_{f}_noise_corrected": e[f"R_{f}_noise_corrected"] for f in FIELDS}}
    return out, mean, se


def paired_difference(Sa, Sb, n_boot=300):
    """Differences b - a of the peak statistics over members sharing base states."""
    t, z, H, hb = Sa["times"], Sa["z"], Sa["H"], Sa["bin_height"]
    n = min(Sa["w"].shape[0], Sb["w"].shape[0])

    def stat(idx):
        pa = A.peak_stats(Sa["w"][idx].mean(0), t, z, H, hb)
        pb = A.peak_stats(Sb["w"][idx].mean(0), t, z, H, hb)
        return {k: pb[k] - pa[k] for k in ("t_peak", "max_w_peak", "t_peak_W1", "W1_peak", "W1_decay_rate")}

    bs = A.bootstrap(list(range(n)), stat, n_boot=n_boot, seed=1)
    return {k: {"value": v, "se": s} for k, (v, s) in bs.items()}


def subsets(S, size=10):
    """Peak statistics of disjoint ``size``-member subsets (what one 10-run study sees)."""
    n = S["w"].shape[0] // size
    out = []
    for k in range(n):
        idx = np.arange(k * size, (k + 1) * size)
        out.append(A.peak_stats(S["w"][idx].mean(0), S["times"], S["z"], S["H"], S["bin_height"]))
    return out


def sensitivity(cache_dir, times, steps, H=30.0, bin_height=2.0):
    """Secondary-peak statistics of iCIDR (binned like the DEM) for Table 1 and
    each parameter moved by +-steps[name]; derivatives by central differences."""
    from icidr_pde.rheology import Material

    base = Material()
    z = (np.arange(int(round(H / bin_height))) + 0.5) * bin_height

    def stats(mat):
        c = binned(continuum_raw(mat, times, cache_dir), H, bin_height)
        return A.peak_stats(c["w"], np.asarray(times), z, H, bin_height)

    out = {"table1": stats(base), "steps": steps, "derivatives": {}, "runs": {}}
    for name, h in steps.items():
        lo = stats(Material(**{**base.to_dict(), name: getattr(base, name) - h}))
        hi = stats(Material(**{**base.to_dict(), name: getattr(base, name) + h}))
        out["runs"][name] = {"minus": lo, "plus": hi}
        out["derivatives"][name] = {k: (hi[k] - lo[k]) / (2 * h)
                                    for k in ("t_peak", "max_w_peak", "t_peak_W1", "W1_peak", "W1_decay_rate")}
    return out


def cpu_seconds(cache_dir):
    """CPU seconds of all cached transient DEM work, steady (pool) runs and continuum runs."""
    tot_dem = tot_cont = tot_steady = 0.0
    for p in Path(cache_dir).glob("*.npz"):
        with np.load(p) as f:
            if "cpu_total" in f.files:
                tot_steady += float(f["cpu_total"])
            elif "cpu_s" in f.files:
                if p.name.startswith("continuum_"):
                    tot_cont += float(f["cpu_s"])
                else:
                    tot_dem += float(f["cpu_s"]) + float(f["cpu_base_s"]) if "cpu_base_s" in f.files else 0.0
    return tot_dem, tot_cont, tot_steady


def definitions(results, cont_raw_t1, phi0, H=30.0):
    """Effect of bin size, velocity definition and frame of u on the baseline."""
    out = {}
    for hb in (1.0, 2.0, 3.0, 5.0):
        S = A.stack(results, hb)
        mean, se = _mean_se(S)
        c = binned(cont_raw_t1, H, hb)
        e = A.errors(mean, c, phi0, S["V0"], H, S["z"], se)
        pk = A.peak_stats(mean["w"], S["times"], S["z"], H, hb)
        out[f"bin_{hb:g}d"] = {"E_max": float(e["E"].max()), "R_u": e["R_u"], "R_w": e["R_w"],
                               "R_phi": e["R_phi"], "max_w_peak": pk["max_w_peak"], "t_peak": pk["t_peak"],
                               "W1_peak": pk["W1_peak"], "t_peak_W1": pk["t_peak_W1"],
                               "icidr_max_w_peak": A.peak_stats(c["w"], S["times"], S["z"], H, hb)["max_w_peak"]}
    c2 = binned(cont_raw_t1, H, 2.0)
    for definition in ("slab_mass", "area_times_mass", "centre"):
        for frame in ("offset", "layers", "lab"):
            S = A.stack(results, 2.0, definition, frame)
            mean, se = _mean_se(S)
            e = A.errors(mean, c2, phi0, S["V0"], H, S["z"], se)
            pk = A.peak_stats(mean["w"], S["times"], S["z"], H, 2.0)
            out[f"{definition}/{frame}"] = {"E_u_max": float(e["E_u"].max()), "R_u": e["R_u"],
                                            "R_w": e["R_w"], "max_w_peak": pk["max_w_peak"],
                                            "W1_peak": pk["W1_peak"]}
    return out


def constitutive_summary(lr, I_low=0.05):
    """Medians of iCIDR-on-DEM-state over DEM for p and tau_xz, by time window and
    for low-I bins (I < I_low) against the rest."""
    rp = lr["p_icidr"] / lr["p"]
    rt = lr["tau_xz_icidr"] / lr["tau_xz"]
    low = lr["I"] < I_low
    early = np.asarray(lr["t"]) < 2.0
    dil = lr["wz"] > 0
    out = {"early_dilating": {"median_ratio_p": float(np.median(rp[early][dil[early]])),
                              "median_ratio_tau_xz": float(np.median(rt[early][dil[early]])),
                              "median_DEM_p": float(np.median(lr["p"][early][dil[early]]))},
           "early_compacting": {"median_ratio_p": float(np.median(rp[early][~dil[early]])),
                                "median_ratio_tau_xz": float(np.median(rt[early][~dil[early]])),
                                "median_DEM_p": float(np.median(lr["p"][early][~dil[early]]))},
           "early_means": "t < 2 (first two 1-unit windows); dilating: DEM w_z > 0","definition": "ratio iCIDR(phi_DEM, u_z DEM, w_z DEM) / DEM measured, 1-unit windows, 2 d bins",
           "I_low": I_low, "fraction_low_I": float(low.mean()),
           "median_ratio_p": {"all": float(np.median(rp)), "low_I": float(np.median(rp[low])) if low.any() else None,
                              "other": float(np.median(rp[~low]))},
           "median_ratio_tau_xz": {"all": float(np.median(rt)),
                                   "low_I": float(np.median(rt[low])) if low.any() else None,
                                   "other": float(np.median(rt[~low]))},
           "by_window": [{"t": float(t), "median_ratio_p": float(np.median(a)), "median_ratio_tau_xz": float(np.median(b)),
                          "min_I": float(i.min())}
                         for t, a, b, i in zip(lr["t"], rp, rt, lr["I"])]}
    return out


def departure_map(mean, se, cont, z):
    """(DEM - iCIDR)/standard error per bin and time for phi, u, w, and the first
    times at which the difference exceeds 3 standard errors in at least two bins."""
    out, first = {}, {}
    for f in FIELDS:
        with np.errstate(invalid="ignore", divide="ignore"):
            zmap = (mean[f] - cont[f]) / se[f]
        zmap[~np.isfinite(zmap)] = 0.0
        out[f] = zmap
        hit = np.nonzero((np.abs(zmap[1:]) > 3).sum(axis=1) >= 2)[0]
        if hit.size == 0:
            first[f] = None
        else:
            k = 1 + hit[0]
            first[f] = {"t": float(mean["times"][k]), "z_of_bins": z[np.abs(zmap[k]) > 3].tolist()}
    return out, first


def make_report(cache_dir, json_path, npz_path=None, fig_path=None, base_factor="baseline",
                n_boot=300, progress=True):
    """Assemble the audit from the cache; returns the summary dict."""
    import json as _json

    from icidr_pde.rheology import Material

    from .paths import committed
    c0 = time.process_time()
    fit = _json.loads(committed("steady.json").read_text())["fit"]
    res = {name: audit.load_factor(name, cache_dir) for name in audit.FACTORS}
    res = {k: v for k, v in res.items() if len(v) >= 2}
    if base_factor not in res:
        raise RuntimeError(f"no cached members of {base_factor!r} in {cache_dir}")
    S0 = A.stack(res[base_factor])
    times, H, phi0 = S0["times"], S0["H"], float(res[base_factor][0]["phi0"])
    raw_t1 = continuum_raw(Material(), times, cache_dir)
    raw_fit = continuum_raw(Material(**fit), times, cache_dir)
    c_t1, c_fit = binned(raw_t1, H, 2.0), binned(raw_fit, H, 2.0)
    z = S0["z"]
    summary = {"factors": {}, "paired_vs_baseline": {}, "phi0": phi0, "table1": Material().to_dict(),
               "fitted": fit}
    curves = {"times": times.astype(np.float32), "z": z}
    for name, rs in res.items():
        S = A.stack(rs)
        fs, mean, se = factor_summary(S, c_t1, c_fit, phi0, n_boot)
        base, pert = audit.FACTORS[name]
        fs["base_state"] = {"preparation": base.preparation, "t_shear": base.t_shear,
                            "n_particles": base.params.n_particles, "H": base.params.H}
        fs["perturbation"] = {"fluctuations": pert.fluctuations, "dt_fraction": pert.dt_fraction
                              or base.params.dt_fraction}
        summary["factors"][name] = fs
        boot_mw = []
        rng = np.random.default_rng(2)
        for _ in range(100):
            idx = rng.integers(0, S["w"].shape[0], S["w"].shape[0])
            boot_mw.append(np.abs(S["w"][idx].mean(0)).max(-1))
        curves[f"{name}_max_w"] = np.abs(mean["w"]).max(-1).astype(np.float32)
        curves[f"{name}_max_w_se"] = np.std(boot_mw, axis=0, ddof=1).astype(np.float32)
        curves[f"{name}_W1"] = A.mode_amplitude(mean["w"], z, H, 2.0).astype(np.float32)
        if name == base_factor:
            M0, SE0 = mean, se
        elif audit.FACTORS[name][0] == audit.FACTORS[base_factor][0]:
            summary["paired_vs_baseline"][name] = paired_difference(S0, S, n_boot)
        if progress:
            print(f"summarised {name} ({len(rs)} members)", flush=True)
    for f in FIELDS:
        curves[f"{base_factor}_{f}_mean"] = M0[f].astype(np.float32)
        curves[f"{base_factor}_{f}_se"] = SE0[f].astype(np.float32)
        curves[f"icidr_table1_{f}"] = c_t1[f].astype(np.float32)
        curves[f"icidr_fitted_{f}"] = c_fit[f].astype(np.float32)
    for nm, c in (("table1", c_t1), ("fitted", c_fit)):
        curves[f"icidr_{nm}_max_w"] = np.abs(c["w"]).max(-1).astype(np.float32)
        curves[f"icidr_{nm}_W1"] = A.mode_amplitude(c["w"], z, H, 2.0).astype(np.float32)
        summary[f"icidr_{nm}_peak"] = A.peak_stats(c["w"], times, z, H, 2.0)
    summary["ensemble_size"] = {"subsets_of_10": subsets(S0, 10)}
    for k in range(S0["w"].shape[0] // 10):
        curves[f"subset{k}_max_w"] = np.abs(S0["w"][10 * k:10 * (k + 1)].mean(0)).max(-1).astype(np.float32)
    summary["definitions"] = definitions(res[base_factor], raw_t1, phi0, H)
    dmap, first = departure_map(M0, SE0, c_t1, z)
    summary["departure_first_time_3se"] = first
    for f in FIELDS:
        curves[f"departure_{f}"] = dmap[f].astype(np.float32)
    lr = A.local_rheology(res[base_factor], M0)
    lr.update(A.constitutive_residual(lr))
    for k, v in lr.items():
        curves[f"local_{k}"] = np.asarray(v, np.float32)
    summary["constitutive_check"] = constitutive_summary(lr)
    steps = {"mu_s": 0.009, "mu_d": 0.034, "I0": 0.041, "phi_c": 0.0018, "a": 0.015}
    summary["sensitivity"] = sensitivity(cache_dir, times, steps, H)
    summary["sensitivity"]["steps_are"] = "1 sigma of our fit of Table 1 (data/dem/steady.json)"
    dem_cpu, cont_cpu, steady_cpu = cpu_seconds(cache_dir)
    summary["cpu_s"] = {"dem_transient_runs": dem_cpu, "dem_steady_pool_runs": steady_cpu,
                        "continuum_runs": cont_cpu,
                        "this_report": time.process_time() - c0}
    Path(json_path).parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(summary, indent=1, default=float)
    write_atomically(json_path, lambda fh: fh.write(text))
    if npz_path:
        with replacing(npz_path) as tmp:
            np.savez_compressed(tmp, **curves)
    if fig_path:
        from .plots import fig8_audit
        fig8_audit(summary, curves, fig_path)
    return summary
