"""Figures: fig 1 (steady mu(I), Phi(I)), fig 8 (transient) and the error figure."""

from __future__ import annotations

import numpy as np

from ..outputs import save_figure
from .fit import mu_of_I

FIG8_TIMES = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0)


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def fig1(summary: dict, path):
    """mu(I) and phi(I): DEM points (mean +- std over repeats), (2.10)/(2.11) with
    Table 1 and with our fit."""
    plt = _plt()
    pts = summary["points"]
    I = np.array([p["I"] for p in pts])
    Is = np.array([p["I_std"] for p in pts])
    mu = np.array([p["mu"] for p in pts])
    mus = np.array([p["mu_std"] for p in pts])
    phi = np.array([p["phi"] for p in pts])
    Ig = np.linspace(1e-3, max(0.3, 1.2 * I.max()), 300)
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
    t1, ft = summary.get("table1"), summary.get("fit")
    ax[0].errorbar(I, mu, xerr=Is, yerr=mus, fmt="o", color="k", ms=4, capsize=2,
                   label=f"LAMMPS DEM ({summary['repeats']} repeats, N={summary['n_particles']})")
    ax[1].errorbar(I, phi, xerr=Is, fmt="o", color="k", ms=4, capsize=2, label="LAMMPS DEM")
    for par, style, lab in ((t1, "-", "Table 1"), (ft, "--", "our fit")):
        if par:
            ax[0].plot(Ig, mu_of_I(Ig, par["mu_s"], par["mu_d"], par["I0"]), style, color="C0" if lab == "Table 1" else "C3", label=f"(2.10) {lab}")
            ax[1].plot(Ig, par["phi_c"] - par["a"] * Ig, style, color="C0" if lab == "Table 1" else "C3", label=f"(2.11) {lab}")
    ax[0].set(xlabel="I", ylabel=r"$\mu$", title="(a) bulk friction")
    ax[1].set(xlabel="I", ylabel=r"$\phi$", title="(b) packing fraction")
    for a in ax:
        a.set_xlim(0, Ig.max())
        a.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=130)
    plt.close(fig)


def fig8(ens: dict, cont_t1: dict, cont_fit: dict, err_t1: dict, err_fit: dict, path,
         times=FIG8_TIMES):
    """Top: profiles of phi, u, w (DEM mean +- std; iCIDR Table 1 solid, our fit
    dashed) at several times and max|w|(t).  Bottom: the error E_f(t) of both
    parameter sets with the DEM ensemble standard error."""
    plt = _plt()
    tt = np.asarray(ens["times"])
    z = np.asarray(ens["z"])
    fig, axs = plt.subplots(2, 4, figsize=(16, 8))
    cmap = plt.get_cmap("viridis")
    for j, t in enumerate(times):
        k = int(np.argmin(np.abs(tt - t)))
        col = cmap(j / max(1, len(times) - 1))
        for ax, f in zip(axs[0, :3], ("phi", "u", "w")):
            ax.errorbar(ens[f"{f}_mean"][k], z, xerr=ens[f"{f}_std"][k], fmt="o", ms=3, color=col,
                        capsize=1.5, label=f"t={tt[k]:.3g}" if f == "phi" else None)
            ax.plot(cont_t1[f][k], z, "-", color=col)
            ax.plot(cont_fit[f][k], z, "--", color=col)
    axs[0, 0].set(xlabel=r"$\phi$", ylabel="z", title="(a)")
    axs[0, 1].set(xlabel="u (frame of the bottom boundary)", title="(b)")
    axs[0, 2].set(xlabel="w", title="(c)")
    axs[0, 0].legend(fontsize=7)
    ax = axs[0, 3]
    ax.plot(tt, ens["max_w"], "k.", ms=3, label=f"DEM ensemble mean ({ens['repeats']} runs)")
    ax.plot(tt, cont_t1["max_w"], "-", color="C0", label="iCIDR, Table 1")
    ax.plot(tt, cont_fit["max_w"], "--", color="C3", label="iCIDR, our fit")
    ax.set(xlabel="t", ylabel=r"max$_z|w|$ (2 d bins)", yscale="log", title="(d)")
    ax.legend(fontsize=7)
    for ax, f in zip(axs[1, :3], ("phi", "u", "w")):
        ax.plot(tt, 100 * err_t1[f], "-", color="C0", label="Table 1")
        ax.plot(tt, 100 * err_fit[f], "--", color="C3", label="our fit")
        ax.plot(tt, 100 * err_t1[f"{f}_floor"], ":", color="gray", label="DEM standard error")
        ax.axhline(2.5, color="k", lw=0.6, label="2.5 % (paper)")
        scale = r"$\phi_0$" if f == "phi" else "$V_0$"
        ax.set(xlabel="t", ylabel=f"$E_{{{f}}}$ [%] (RMS over bins / {scale})", title=f"(e) error in {f}")
        ax.legend(fontsize=7)
    ax = axs[1, 3]
    ax.plot(tt, 100 * err_t1["total"], "-", color="C0", label="Table 1")
    ax.plot(tt, 100 * err_fit["total"], "--", color="C3", label="our fit")
    ax.axhline(2.5, color="k", lw=0.6, label="2.5 % (paper)")
    ax.set(xlabel="t", ylabel="E = max_f E_f [%]", title="(f) relative error E(t)")
    ax.legend(fontsize=7)
    fig.suptitle("Sine-perturbed shear cell (5.7), phi0=0.78, a=0.16, b=0.1: "
                 "DEM (symbols, mean $\\pm$ std) vs iCIDR (solid: Table 1, dashed: our fit)", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path, dpi=90)
    plt.close(fig)


def fig8_audit(summary: dict, c: dict, path):
    """Protocol audit of fig 8(d): (a) max|w| with bootstrap bands and 10-member
    subsets, (b) the first sine mode W1 per factor, (c) where DEM departs from
    iCIDR in (z, t), (d, e) the DEM transient against the steady laws, (f) the
    continuum's secondary-peak sensitivity to the Table 1 parameters."""
    plt = _plt()
    from .fit import mu_of_I

    t = np.asarray(c["times"], float)
    z = np.asarray(c["z"], float)
    fig, axs = plt.subplots(2, 3, figsize=(16, 9))
    ax = axs[0, 0]
    m, se = c["baseline_max_w"], c["baseline_max_w_se"]
    R = summary["factors"]["baseline"]["repeats"]
    ax.fill_between(t, m - 2 * se, m + 2 * se, color="k", alpha=0.2, lw=0)
    ax.plot(t, m, "k-", lw=1.2, label=f"DEM baseline, {R} members (band: 2 s.e., bootstrap)")
    ax.plot(t, c["icidr_table1_max_w"], "-", color="C0", label="iCIDR, Table 1")
    ax.plot(t, c["icidr_fitted_max_w"], "--", color="C3", label="iCIDR, our fit")
    for k in range(3):
        key = f"subset{k}_max_w"
        if key in c:
            ax.plot(t, c[key], "-", lw=0.6, color="0.5", label="10-member subsets" if k == 0 else None)
    ax.set(xlabel="t", ylabel=r"max$_z|w|$ (2 d bins)", yscale="log", ylim=(2e-3, 0.15),
           title="(a) fig 8(d): is the secondary peak noise?")
    ax.legend(fontsize=7)
    ax = axs[0, 1]
    for j, name in enumerate(summary["factors"]):
        ax.plot(t, c[f"{name}_W1"], lw=1.0, color=f"C{j}", label=f"DEM {name}")
    ax.plot(t, c["icidr_table1_W1"], "k-", lw=2, label="iCIDR, Table 1")
    ax.axhline(0, color="k", lw=0.5)
    ax.set(xlabel="t", ylabel=r"$W_1$: amplitude of sin(2$\pi$z/H) in w", ylim=(-0.03, 0.045),
           title="(b) slow mode per protocol factor")
    ax.legend(fontsize=6)
    ax = axs[0, 2]
    d = np.clip(c["departure_w"], -8, 8)
    pc = ax.pcolormesh(t, z, d.T, cmap="RdBu_r", vmin=-8, vmax=8, shading="nearest")
    fig.colorbar(pc, ax=ax, label=r"($w_{DEM}-w_{iCIDR}$)/s.e.")
    ax.contour(c["local_t"], z, c["local_I"].T, levels=[0.05], colors="k", linewidths=1)
    ax.set(xlabel="t", ylabel="z", title="(c) where DEM departs (black: DEM local I = 0.05)")
    t1 = summary.get("table1", None) or {"mu_s": 0.248, "mu_d": 0.588, "I0": 0.145, "phi_c": 0.817, "a": 0.314}
    Ig = np.linspace(0.0, 0.3, 100)
    tl = np.asarray(c["local_t"])
    for ax, key, lab in ((axs[1, 0], "phi", r"$\phi$"), (axs[1, 1], "mu", r"$\mu = \|\tau\|/p$")):
        TT = np.repeat(tl[:, None], z.size, axis=1)
        sc = ax.scatter(c["local_I"].ravel(), c[f"local_{key}"].ravel(), c=TT.ravel(), s=6, cmap="viridis")
        if key == "phi":
            ax.plot(Ig, t1["phi_c"] - t1["a"] * Ig, "r-", label=r"(2.11) Table 1")
        else:
            ax.plot(Ig[1:], mu_of_I(Ig[1:], t1["mu_s"], t1["mu_d"], t1["I0"]), "r-", label="(2.10) Table 1")
        ax.set(xlabel=r"DEM local I = 2d$\|S\|/\sqrt{p/\rho_*}$", ylabel=lab, xlim=(0, 0.3),
               title=f"({'d' if key == 'phi' else 'e'}) DEM transient vs the steady law (1-unit windows)")
        fig.colorbar(sc, ax=ax, label="t")
        ax.legend(fontsize=7)
    axs[1, 0].set_ylim(0.74, 0.82)
    axs[1, 1].set_ylim(0, 0.8)
    ax = axs[1, 2]
    sens = summary["sensitivity"]
    names = list(sens["steps"])
    dh = [sens["derivatives"][n]["max_w_peak"] * sens["steps"][n] for n in names]
    dt_ = [sens["derivatives"][n]["t_peak_W1"] * sens["steps"][n] for n in names]
    x = np.arange(len(names))
    ax.bar(x - 0.2, dh, 0.4, label=r"$\Delta$ peak max|w| per 1 $\sigma$")
    ax2 = ax.twinx()
    ax2.bar(x + 0.2, dt_, 0.4, color="C1", label=r"$\Delta t$ of the W1 peak per 1 $\sigma$")
    gap = summary["factors"]["baseline"]["peak"]["max_w_peak"]["value"] - summary["icidr_table1_peak"]["max_w_peak"]
    ax.axhline(gap, color="C0", ls=":", label=f"DEM - iCIDR peak height ({gap:.3f})")
    ax.set_xticks(x, names)
    ax.set(ylabel=r"$\Delta$ max|w| peak", title="(f) iCIDR secondary peak: local sensitivity (1 sigma of fit)")
    ax2.set_ylabel(r"$\Delta t$ (W1 peak)")
    ax.legend(fontsize=7, loc="upper left")
    ax2.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    save_figure(fig, path, dpi=85)
    plt.close(fig)


def fig1_pool(pool: dict, path):
    """Fig 1 as the paper pools it: points of every configuration (marker per
    configuration; error bars = the standard errors used in the fits), (2.10) and
    (2.11) with Table 1, with the reference sweep's fit and with the pooled fit."""
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    markers = "os^vD<>Xp"
    configs = list(dict.fromkeys(p["config"] for p in pool["points"]))
    for j, cfg in enumerate(configs):
        pts = [p for p in pool["points"] if p["config"] == cfg]
        I = np.array([p["I"] for p in pts])
        kw = dict(fmt=markers[j % len(markers)], ms=4, capsize=2, mfc="none", color=f"C{j}")
        ax[0].errorbar(I, [p["mu"] for p in pts], xerr=[p["se_I"] for p in pts],
                       yerr=[p["se_mu"] for p in pts], label=cfg, **kw)
        ax[1].errorbar(I, [p["phi"] for p in pts], xerr=[p["se_I"] for p in pts], label=cfg, **kw)
    Ig = np.linspace(1e-3, 0.3, 300)
    for par, style, lab in ((pool["table1"], "-", "Table 1"), (pool["reference_fit"]["fit"], ":", "reference fit"),
                            (pool["pooled_fit"]["fit"], "--", "pooled fit")):
        ax[0].plot(Ig, mu_of_I(Ig, par["mu_s"], par["mu_d"], par["I0"]), style, color="k", lw=1, label=lab)
        ax[1].plot(Ig, par["phi_c"] - par["a"] * Ig, style, color="k", lw=1, label=lab)
    ax[0].set(xlabel="I", ylabel=r"$\mu$", title="(a) bulk friction, pooled")
    ax[1].set(xlabel="I", ylabel=r"$\phi$", title="(b) packing fraction, pooled")
    for a in ax:
        a.set_xlim(0, 0.22)
        a.legend(fontsize=6)
    ax[0].set_ylim(0.3, 0.5)
    ax[1].set_ylim(0.755, 0.805)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)
    plt.close(fig)
