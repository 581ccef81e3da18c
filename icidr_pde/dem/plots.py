"""Figures: fig 1 (steady mu(I), Phi(I)), fig 8 (transient) and the error figure."""

from __future__ import annotations

import numpy as np

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
    fig.savefig(path, dpi=130)
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
    fig.savefig(path, dpi=90)
    plt.close(fig)
