"""Figures 1 and 8: the DEM (LAMMPS) steady mu(I), phi(I) and the transient against iCIDR, from committed data."""

from __future__ import annotations

import json

import numpy as np

from .panels import line_colors, pyplot
from .registry import register_figure
from .runs import DATA, FIG7_TIMES

__all__ = ["fig1", "fig8"]


@register_figure("fig1", "Steady DEM mu(I) and phi(I) (LAMMPS, committed data) pooled over k_n, H and N, "
                         "with (2.10), (2.11) and Table 1",
                 "Fig 1: (a) mu and (b) phi against I; blue lines (2.10), (2.11) with Table 1; symbols DEM "
                 "(one marker per k_n, H, N configuration); dashed: fit to the pool",
                 source="data/dem/steady.json, data/dem/steady_pool.json")
def fig1(runs):
    from ..rheology import Material

    plt = pyplot()
    summary = json.loads((DATA / "dem" / "steady.json").read_text())
    pool_path = DATA / "dem" / "steady_pool.json"
    pool = json.loads(pool_path.read_text()) if pool_path.exists() else None
    pts = summary["points"]
    I, dI = np.array([p["I"] for p in pts]), np.array([p["I_std"] for p in pts])
    mu, dmu = np.array([p["mu"] for p in pts]), np.array([p["mu_std"] for p in pts])
    phi = np.array([p["phi"] for p in pts])
    m = Material()
    Ig = np.linspace(0, 0.3, 301)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    axes[0].errorbar(I, mu, xerr=dI, yerr=dmu, fmt="o", color="k", mfc="none", ms=5, capsize=2,
                     label=f"DEM ({summary['repeats']} repeats, {summary['n_particles']} disks; std)")
    axes[1].errorbar(I, phi, xerr=dI, fmt="o", color="k", mfc="none", ms=5, capsize=2, label="DEM reference")
    numbers = {}
    if pool is not None:
        configs = [c for c in dict.fromkeys(p["config"] for p in pool["points"]) if c != "reference"]
        for j, cfg in enumerate(configs):
            cp = [p for p in pool["points"] if p["config"] == cfg]
            x = np.array([p["I"] for p in cp])
            kw = dict(fmt="s^vD<>p"[j % 7], ms=4, mfc="none", capsize=1.5, color=f"C{j + 1}")
            axes[0].errorbar(x, [p["mu"] for p in cp], xerr=[p["se_I"] for p in cp],
                             yerr=[p["se_mu"] for p in cp], label=f"{cfg} (s.e.)", **kw)
            axes[1].errorbar(x, [p["phi"] for p in cp], xerr=[p["se_I"] for p in cp], label=cfg, **kw)
        f = pool["pooled_fit"]["fit"]
        axes[0].plot(Ig, f["mu_s"] + (f["mu_d"] - f["mu_s"]) / (f["I0"] / np.maximum(Ig, 1e-12) + 1), "k--",
                     lw=1, label="(2.10), pooled fit")
        axes[1].plot(Ig, f["phi_c"] - f["a"] * Ig, "k--", lw=1, label="(2.11), pooled fit")
        numbers = {"pooled_fit": f, "pooled_fit_std": pool["pooled_fit"]["std"],
                   "pooled_points": len(pool["points"]), "configs": configs}
    axes[0].plot(Ig, m.mu(Ig), color="tab:blue", label="(2.10), Table 1")
    axes[1].plot(Ig, m.Phi(Ig), color="tab:blue", label="(2.11), Table 1")
    axes[0].set(xlabel="I", ylabel=r"$\mu$", title="(a)", xlim=(0, 0.3))
    axes[1].set(xlabel="I", ylabel=r"$\phi$", title="(b)", xlim=(0, 0.3))
    for ax in axes:
        ax.legend(fontsize=6)
    fig.tight_layout()
    residual_mu = float(np.max(np.abs(mu - m.mu(I))))
    residual_phi = float(np.max(np.abs(phi - m.Phi(I))))
    return fig, {"I_range": [float(I.min()), float(I.max())], "max_abs_mu_minus_table1": residual_mu,
                 "max_abs_phi_minus_table1": residual_phi, "fit": summary.get("fit"), **numbers}


@register_figure("fig8", "iCIDR (Table 1) against the mean of {dem_runs} DEM runs from IC (5.7): phi, u, w and "
                 "max|w|(t)",
                 "Fig 8: (a-c) phi, u, w profiles, DEM mean (circles) +- std (bars) against iCIDR; (d) max|w|(t)",
                 source="data/dem/transient_ensemble.npz")
def fig8(runs):
    plt = pyplot()
    ens = np.load(DATA / "dem" / "transient_ensemble.npz")
    tt, z = ens["times"], ens["z"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4))
    for j, t in enumerate(FIG7_TIMES):
        k = int(np.argmin(np.abs(tt - t)))
        color = line_colors(len(FIG7_TIMES))[j]
        for ax, f in zip(axes[:3], ("phi", "u", "w")):
            ax.errorbar(z, ens[f"{f}_mean"][k], yerr=ens[f"{f}_std"][k], fmt="o", ms=3, mfc="none", color=color,
                        capsize=1.5, label=f"t = {t:g}" if f == "phi" else None)
            ax.plot(z, ens[f"icidr_table1_{f}"][k], "-", color=color)
    for ax, label, letter in zip(axes[:3], (r"$\phi$", "u", "w"), "abc"):
        ax.set(xlabel="z", ylabel=label, title=f"({letter})")
    axes[0].legend(fontsize=6)
    ax = axes[3]
    icidr_max = np.max(np.abs(ens["icidr_table1_w"]), axis=1)
    repeats = int(ens["repeats"])
    ax.plot(tt, ens["max_w"], "ko", mfc="none", ms=3, label=f"DEM mean of {repeats} runs")
    ax.plot(tt, icidr_max, color="tab:red", label="iCIDR (Table 1), same bins")
    ax.set(xlabel="t", ylabel="max|w| (2d bins)", yscale="log", title="(d)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    summary = json.loads((DATA / "dem" / "transient.json").read_text())
    return fig, {"dem_runs": repeats, "rel_error_table1_max": summary["rel_error_table1_summary"]["max"],
                 "secondary_max_w_peak": summary.get("secondary_max_w_peak")}
