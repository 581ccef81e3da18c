"""The paper's figures 2-7 of the 1-D shear cell: mu(I),Phi(I) blows up on refinement (figs 2-4),
the iCIDR yield ratio (fig 5), iCIDR converges (figs 6, 7)."""

from __future__ import annotations

import json

import numpy as np

from .panels import (
    chi_infinite_z, grid_difference, grid_pair, line_colors, max_w_extrema, max_w_pair, positive_intervals, pyplot,
    scheme_label, snapshot_at, tstar_label)
from .registry import register_figure
from .runs import DATA, FIG6_TIMES, FIG7_TIMES, PAPER_TSTAR_CHEB

__all__ = ["FIG5_PHI", "fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "yield_ratio"]


# --- figure 2 ----------------------------------------------------------------------------------------------------------

@register_figure("fig2", "Initial condition (3.16) and chi (A18) of mu(I),Phi(I): ill-posed (chi > 0) in the centre",
                 "Fig 2: u(z,0), w(z,0), phi(z,0) for IC (3.16), phi0 = 0.78, eps = 0.05, H = 30; (d) chi(z)")
def fig2(runs):
    plt = pyplot()
    res = runs["mui-fd-fine"]
    fig, axes = plt.subplots(1, 4, figsize=(13, 3.3))
    for ax, name, label, letter in zip(axes[:3], ("u", "w", "phi"), ("u", "w", r"$\phi$"), "abc"):
        ax.plot(res.z, getattr(res, name)[0], "k")
        ax.set(xlabel="z", ylabel=label, title=f"({letter})", xlim=(0, 30))
    axes[2].set_ylim(0.77, 0.79)
    z_chi, chi = res.chi_z, res.chi[0]
    ax = axes[3]
    ax.plot(z_chi, chi, "k")
    ax.axhline(0, color="gray", lw=0.6)
    intervals = positive_intervals(z_chi, chi)
    for a, b in intervals:
        ax.axvspan(a, b, color="tab:red", alpha=0.15)
    ax.set(xlabel="z", ylabel=r"$\chi$", title="(d)  shaded: $\\chi > 0$ (ill-posed)", xlim=(0, 30))
    fig.tight_layout()
    return fig, {"chi_positive_z": intervals, "chi_max": float(np.max(chi)), "chi_min": float(np.min(chi)),
                 "max_w0": float(np.max(np.abs(res.w[0])))}


# --- figure 3 ----------------------------------------------------------------------------------------------------------

def _blowup_times(res, fractions=(0.25, 0.5, 0.7, 0.85, 0.95)):
    """Snapshot times (multiples of BLOWUP_DT) at about these fractions of t*, and the last one before t*."""
    reached = res.times[res.times > 0]
    if not res.blew_up or len(reached) == 0:
        return []
    picked = {float(reached[np.argmin(np.abs(reached - f * res.t_star))]) for f in fractions}
    picked.add(float(reached[-1]))
    return sorted(picked)


def _blowup_panel(ax, res, letter, title):
    """w at a few times up to the last snapshot before t*, the IC dashed. The state at t* itself is
    not drawn: the integrator's last accepted state is grid-scale noise of size ~1e6-1e10 everywhere,
    which hides where the growth started (the centre); its size is printed instead."""
    times = _blowup_times(res)
    for t, c in zip(times, line_colors(len(times))):
        ax.plot(res.z, res.w[snapshot_at(res, t)], color=c, lw=1, label=f"t = {t:.4g}")
    ax.plot(res.z, res.w[0], "k--", lw=1.2, label="t = 0 (3.16)")
    if res.blew_up:
        ax.text(0.02, 0.03, f"fails at t* = {res.t_star:.4g}: max|w| = {np.max(np.abs(res.final[2])):.2g}",
                transform=ax.transAxes, fontsize=8, color="tab:red")
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30), title=f"({letter}) {title}")
    ax.legend(fontsize=7, loc="upper left")


@register_figure("fig3", "mu(I),Phi(I) w snapshots: N = 201 fails (fd, Chebyshev), N = 47 decays",
                 "Fig 3: w snapshots, (a) finite differences N = 201, (b) Chebyshev N = 201, (c) finite "
                 "differences N = 47; IC dashed black")
def fig3(runs):
    plt = pyplot()
    fd, cheb, coarse = runs["mui-fd-fine"], runs["mui-cheb-fine"], runs["mui-fd-coarse"]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    _blowup_panel(axes[0], fd, "a", f"{scheme_label(fd)}, N = {fd.N}: {tstar_label(fd)}")
    _blowup_panel(axes[1], cheb, "b", f"{scheme_label(cheb)}, N = {cheb.N}: {tstar_label(cheb)}")
    ax = axes[2]
    shown = [t for t in FIG6_TIMES if t > 0]
    for t, c in zip(shown, line_colors(len(shown))):
        ax.plot(coarse.z, coarse.w[snapshot_at(coarse, t)], color=c, label=f"t = {t:g}")
    ax.plot(coarse.z, coarse.w[0], "k--", lw=1.2, label="t = 0 (3.16)")
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30),
           title=f"(c) {scheme_label(coarse)}, N = {coarse.N}: {tstar_label(coarse)}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig, {"t_star_fd_fine": fd.t_star, "t_star_cheb_fine": cheb.t_star, "N_fine": fd.N,
                 "coarse_blew_up": coarse.blew_up, "coarse_max_w_t10": float(np.max(np.abs(coarse.w[-1]))),
                 "max_w0": float(np.max(np.abs(coarse.w[0]))),
                 "argmax_z_before_tstar_fd": float(fd.z[np.argmax(np.abs(fd.w[len(fd.times) - 1]))])}


# --- figure 4 ----------------------------------------------------------------------------------------------------------

#: fig 4(b)'s sweep, written by ``icidr-pde tstar --rheology mui --scene shear --discretization fd cheb
#: --N 21:201:2 --json data/tstar/mui_shear_stated.json`` (its default settings, ``--accuracy stated``)
FIG4B_SWEEP = "mui_shear_stated.json"


def _load_tstar(name, discretization=None):
    """(N, t*) of the committed sweep `name` (NaN: no failure), of its one discretization or `discretization`."""
    path = DATA / "tstar" / name
    from ..studies.failure_time import read_tstar_curves

    curves = read_tstar_curves(json.loads(path.read_text()))  # either form
    (data,) = curves.values() if discretization is None else (curves[discretization],)
    N = np.array(sorted(int(k) for k in data))
    t = np.array([np.nan if data[str(n)] is None else data[str(n)] for n in N], dtype=float)
    return N, t


def _sweep_settings(name, discretization) -> str:
    """How the sweep's runs of `discretization` were computed, as its document records them."""
    s = json.loads((DATA / "tstar" / name).read_text())["discretizations"][discretization]["settings"]
    return f"{s['engine']} {s['method']}, {s['linear_solver']}, rtol {s['rtol']:g}, atol {s['atol']:g}"


def _stated(discretization) -> str:
    from ..studies.failure_time import ACCURACY

    row = ACCURACY["stated"][discretization]
    return f"{row['engine']} {row['method']}, rtol {row['rtol']:g}, atol {row['atol']:g}"


@register_figure("fig4", "max|w|(t) of the four mu(I) runs with t* marked; t*(N) of the Chebyshev scheme "
                         f"(the sweep of icidr-pde tstar's default: {_stated('cheb')})",
                 "Fig 4: (a) max|w|(t), finite differences dashed, Chebyshev solid, N = 201 red, N = 47 blue, "
                 "t* = 0.01052 indicated; (b) t* against N (Chebyshev)", source="computed + data/tstar/")
def fig4(runs):
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    ax = axes[0]
    numbers = {}
    for key, color, ls in (("mui-fd-fine", "tab:red", "--"), ("mui-cheb-fine", "tab:red", "-"),
                           ("mui-fd-coarse", "tab:blue", "--"), ("mui-cheb-coarse", "tab:blue", "-")):
        res = runs[key]
        keep = res.max_w_t > 0
        ax.loglog(res.max_w_t[keep], res.max_w_series[keep], ls=ls, color=color, label=f"{scheme_label(res)}, N = {res.N}")
        if res.blew_up:  # the value at t* (1e6-1e10) is off the axis: the cross sits at its top
            ax.plot([res.t_star], [min(res.max_w_series[-1], 5.0)], "x", color=color, ms=8, clip_on=False)
        numbers[f"t_star_{key}"] = res.t_star
        numbers[f"max_w_final_{key}"] = float(res.max_w_series[-1])
    cheb = runs["mui-cheb-fine"]
    if cheb.blew_up:
        ax.axvline(cheb.t_star, color="k", lw=0.7)
        ax.annotate(f"Chebyshev t* = {cheb.t_star:.4g}\n(paper, N = 201: {PAPER_TSTAR_CHEB})", (cheb.t_star, 0.5),
                    xycoords=("data", "axes fraction"), xytext=(4, 0), textcoords="offset points", fontsize=8)
    ax.plot([], [], "x", color="k", ms=8, label="failure at t* (max|w| off the axis)")
    ax.set(xlabel="t", ylabel="max|w|", title="(a) max|w|(t) of the four runs", xlim=(1e-4, 10), ylim=(1e-4, 5))
    ax.legend(fontsize=8, loc="lower left")
    ax = axes[1]
    N, t = _load_tstar(FIG4B_SWEEP, "cheb")
    ax.plot(N, t, "o", color="k", ms=3, mfc="none",
            label=f"Chebyshev, icidr-pde tstar\n({_sweep_settings(FIG4B_SWEEP, 'cheb')})")
    ax.plot([cheb.N], [cheb.t_star], "*", color="tab:red", ms=12,
            label=f"panel (a)'s run, N = {cheb.N} ({cheb.method}, rtol {cheb.rtol:g})")
    ax.set_yscale("log")
    ax.set(xlabel="$N_z$", ylabel="$t_*$", title="(b)  no failure by t = 20 below the threshold")
    threshold = int(N[np.isfinite(t)].min())
    ax.axvline(threshold - 1, color="gray", lw=0.6, ls=":")
    ax.text(threshold + 3, 0.5 * np.nanmax(t), f"fails for $N_z \\geq$ {threshold}", fontsize=8, va="top")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    numbers.update(paper_t_star=PAPER_TSTAR_CHEB, cheb_threshold_N=threshold,
                   cheb_t_star_N201_data=float(t[N == 201][0]))
    return fig, numbers


# --- figure 5 ----------------------------------------------------------------------------------------------------------

FIG5_PHI = (0.72, 0.74, 0.76, 0.78, 0.80)


def yield_ratio(I, phi, material=None):
    """Y/p of iCIDR (4.7): mu(Psi(phi)) I / Psi(phi)."""
    from ..rheology import Material

    m = Material() if material is None else material
    psi = m.Psi(phi)
    return m.mu(psi) * np.asarray(I, dtype=float) / psi


@register_figure("fig5", "iCIDR yield ratio Y/p against I for several phi, with mu(I) and mu_d",
                 "Fig 5: Y/p against I for several phi (black), mu(I) (blue), steady isochoric points "
                 "I = Psi(phi) (dots), mu_d (dashed red)", source="(4.7), Table 1")
def fig5(runs):
    from ..rheology import Material

    plt = pyplot()
    m = Material()
    I = np.linspace(0, 0.6, 301)
    fig, ax = plt.subplots(figsize=(6, 4.2))
    dots = []
    for phi in FIG5_PHI:
        ax.plot(I, yield_ratio(I, phi, m), "k", lw=1)
        psi = float(m.Psi(phi))
        dots.append([phi, psi, float(m.mu(psi))])
        ax.plot([psi], [m.mu(psi)], "ko", ms=5)
        ax.annotate(f"$\\phi$ = {phi:g}", (I[-1], yield_ratio(I[-1], phi, m)), fontsize=7,
                    xytext=(-40, 4), textcoords="offset points")
    ax.plot(I, m.mu(I), color="tab:blue", lw=2, label=r"$\mu(I)$ (2.10)")
    ax.axhline(m.mu_d, color="tab:red", ls="--", label=r"$\mu_d$")
    ax.set(xlabel="I", ylabel="Y/p", xlim=(0, 0.6), ylim=(0, 1.0))
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig, {"isochoric_points_phi_I_mu": dots, "mu_d": m.mu_d}


# --- figure 6 ----------------------------------------------------------------------------------------------------------

@register_figure("fig6", "iCIDR with IC (3.16): w snapshots and max|w|(t) at N = 47 and 201 on top of one another",
                 "Fig 6: (a) w at a sequence of times, N = 47 (open circles) and N = 201 (lines); (b) max|w|(t), "
                 "N = 47 blue circles, N = 201 red line")
def fig6(runs):
    plt = pyplot()
    coarse, fine = runs["icidr-shear-fd-coarse"], runs["icidr-shear-fd-fine"]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    ax = axes[0]
    grid_pair(ax, coarse, fine, "w", FIG6_TIMES, ms=4)
    ax.set(xlabel="z", ylabel="w", xlim=(0, 30), title=f"(a) lines N = {fine.N}, circles N = {coarse.N}")
    ax.legend(fontsize=7)
    ax = axes[1]
    max_w_pair(ax, coarse, fine, ms=4)
    ax.set(xlabel="t", ylabel="max|w|", yscale="log", xlim=(0, 10), title="(b)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    w0 = np.max(np.abs(fine.w[0]))
    diff = grid_difference(coarse, fine, FIG6_TIMES)
    return fig, {"blew_up": bool(coarse.blew_up or fine.blew_up), "max_w0": float(w0),
                 "max_w_t10_fine": float(np.max(np.abs(fine.w[-1]))),
                 "grid_difference_rel_max_w0": diff / w0, "N": [coarse.N, fine.N]}


# --- figure 7 ----------------------------------------------------------------------------------------------------------

@register_figure("fig7", "iCIDR with IC (5.7): phi, u, w at N = 47 and 201, chi at t = 0, max|w|(t) with its "
                 "local maximum near t = 3",
                 "Fig 7: (a-c) phi, u, w, N = 201 lines, N = 47 open circles; (d) chi (A18) at t = 0; (e) max|w|(t), "
                 "N = 47 open circles, N = 201 red line")
def fig7(runs):
    plt = pyplot()
    coarse, fine = runs["icidr-sine-fd-coarse"], runs["icidr-sine-fd-fine"]
    fig, axes = plt.subplots(1, 5, figsize=(17, 3.8))
    for ax, name, label, letter in zip(axes[:3], ("phi", "u", "w"), (r"$\phi$", "u", "w"), "abc"):
        grid_pair(ax, coarse, fine, name, FIG7_TIMES, ms=3)
        ax.set(xlabel="z", ylabel=label, xlim=(0, 30), title=f"({letter})")
    axes[0].legend(fontsize=6)
    ax = axes[3]
    z_chi, chi = fine.chi_z, fine.chi[0]
    intervals = positive_intervals(z_chi, chi)
    ax.plot(z_chi, np.where(np.isfinite(chi), chi, np.nan), "k")
    inf_z = chi_infinite_z(fine)
    for a, b in intervals:
        ax.axvspan(a, b, color="tab:red", alpha=0.15)
    for zi in inf_z:
        ax.axvline(zi, color="tab:red", lw=0.8, ls=":")
    ax.axhline(0, color="gray", lw=0.6)
    ax.set(xlabel="z", ylabel=r"$\chi$ at t = 0", xlim=(0, 30), ylim=(-10, 10),
           title="(d) shaded $\\chi>0$; dotted $\\chi=\\infty$")
    ax = axes[4]
    max_w_pair(ax, coarse, fine, ms=3)
    extrema = max_w_extrema(fine, t_min=1.0)
    for t, v in extrema["local_maxima"]:
        ax.plot([t], [v], "kv", ms=6)
        ax.annotate(f"local max t = {t:.2f}", (t, v), xytext=(6, 6), textcoords="offset points", fontsize=7)
    ax.set(xlabel="t", ylabel="max|w|", yscale="log", xlim=(0, 20), title="(e)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    w0 = np.max(np.abs(fine.w[0]))
    diff = grid_difference(coarse, fine, FIG7_TIMES)
    return fig, {"chi_positive_z": intervals, "chi_infinite_z": [float(z) for z in inf_z],
                 "max_w_local_maxima_after_t1": extrema["local_maxima"], "blew_up": bool(coarse.blew_up or fine.blew_up),
                 "grid_difference_rel_max_w0": diff / w0, "max_w_t20_fine": float(np.max(np.abs(fine.w[-1])))}
