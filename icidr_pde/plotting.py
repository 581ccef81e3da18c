"""Plot helpers for one Result (``--plot``, ``demo``); the paper's figures are in :mod:`icidr_pde.figures`."""

from __future__ import annotations

from typing import TYPE_CHECKING

import matplotlib.pyplot as plt
import numpy as np

from .outputs import save_figure

if TYPE_CHECKING:  # a Result is what these draw; result.py's Result.plot imports this module
    from .result import Result

__all__ = ["plot_result", "plot_fields", "field_panel", "plot_profiles", "plot_max_w", "demo_figure",
           "last_states_after"]


def plot_profiles(ax, result: Result, field: str = "w", style: str = "-", label_prefix: str = "",
                  t_min: float = -1.0, show_final: bool = False, show_last: bool = False):
    """Snapshots of `field` against z, one line per requested time reached after `t_min`.

    A failed run's state at t* is the integrator's last accepted state, grid-scale noise
    (often largest at the walls) whose size hides where the growth began: it is drawn here
    only if `show_final` (:func:`plot_result` draws it in a panel of its own), otherwise its
    size is written in the panel. `show_last` adds, dashed, the last states the run passed
    after the last snapshot (:attr:`Result.last_states`): the growth before t*.
    """
    data = getattr(result, field)
    index = {"phi": 0, "u": 1, "w": 2}[field]
    shown = [(t, profile) for t, profile in zip(result.times, data) if t > t_min]
    colors = plt.cm.viridis(np.linspace(0, 0.9, max(len(shown), 1)))
    marker = "o" if style == "o" else None
    ls = "none" if style == "o" else style
    for (t, profile), c in zip(shown, colors):
        ax.plot(result.z, profile, ls=ls, marker=marker, mfc="none", ms=4, color=c,
                label=f"{label_prefix}t = {t:g}")
    if show_last:
        last = last_states_after(result, result.times[-1] if len(result.times) else -1.0)
        for (t, state), c in zip(last, plt.cm.autumn(np.linspace(0.6, 0, max(len(last), 1)))):
            ax.plot(result.z, state[index], ls="--", lw=0.9, color=c, label=f"{label_prefix}t = {t:.4g}")
    if result.blew_up:
        if show_final:
            ax.plot(result.z, result.final[index], color="r", lw=0.8,
                    label=f"{label_prefix}t* = {result.t_star:.4g}")
        else:
            ax.text(0.02, 0.03, f"{label_prefix}fails at t* = {result.t_star:.4g} "
                    f"(max|{field}| there {np.max(np.abs(result.final[index])):.2g})",
                    transform=ax.transAxes, fontsize=7, color="r")
    ax.set_xlabel("z")
    ax.set_ylabel(field)


def last_states_after(result: Result, t_after: float) -> list:
    """(t, state) of the run's last states (:attr:`Result.last_states`) later than `t_after`."""
    if result.last_states is None:
        return []
    return [(float(t), state) for t, state in zip(result.last_times, result.last_states) if t > t_after]


def plot_max_w(ax, result: Result, label: str | None = None, **kwargs):
    """max|w|(t) on log-log axes; a failed run ends with an x at t*."""
    t, v = result.max_w_t, result.max_w_series
    keep = t > 0
    label = label or f"{result.rheology} {result.discretization} N={result.N}"
    (line,) = ax.loglog(t[keep], v[keep], label=label, **kwargs)
    if result.blew_up:
        ax.plot([result.t_star], [v[-1]], "x", color=line.get_color(), ms=9)
    ax.set_xlabel("t")
    ax.set_ylabel("max |w|")
    return line


def plot_result(result: Result, path=None):
    """w, u, phi snapshots and max|w|(t); a failed run adds the last states before t*
    (dashed) and, in panels of their own, w and phi at t*. A 2-D run: :func:`plot_fields`."""
    if result.measures is not None:
        return plot_fields(result, path)
    failed = result.blew_up
    fig, axes = plt.subplots(2, 3 if failed else 2, figsize=(15 if failed else 10, 7))
    plot_profiles(axes[0, 0], result, "w", show_last=failed)
    plot_profiles(axes[0, 1], result, "u", show_last=failed)
    plot_profiles(axes[1, 0], result, "phi", show_last=failed)
    plot_max_w(axes[1, 1], result)
    axes[0, 0].legend(fontsize=7)
    if failed:
        for ax, k, name in ((axes[0, 2], 2, "w"), (axes[1, 2], 0, "phi")):
            ax.plot(result.z, result.final[k], color="r", lw=0.8)
            ax.set_title(f"{name} at t* = {result.t_star:.5g} (the last accepted state)", fontsize=9)
            ax.set_xlabel("z")
            ax.set_ylabel(name)
    status = f"failed at t* = {result.t_star:.5g}" if failed else "reached t_end"
    fig.suptitle(f"{result.rheology}, scene {result.scene}, {result.discretization} N = {result.N}: {status}")
    fig.tight_layout()
    if path:
        save_figure(fig, path, dpi=120)
    return fig


def field_panel(ax, result, k, frame, label, state=None, t=None):
    """Image of w (k = "w") or phi - phi0 of snapshot `frame` of a 2-D run of scene bump2d,
    or of `state` (fields first) at time `t` if given."""
    from .cells.plane2d.scenes import Bump2DScene

    scene = Bump2DScene(**{k_: v for k_, v in result.scene_params.items() if k_ in ("L", "H", "phi0", "eps", "ell")})
    if state is None:
        state, t = (result.phi[frame], result.u[frame], result.w[frame]), result.times[frame]
    field = np.asarray(state[2] if k == "w" else state[0] - scene.phi0)
    vmax = float(np.max(np.abs(field))) or 1.0
    im = ax.imshow(field.T, origin="lower", extent=(0, scene.L, 0, scene.H), cmap="RdBu_r", vmin=-vmax, vmax=vmax)
    ax.set_title(f"{label}: {'w' if k == 'w' else 'phi - phi0'}, t = {t:.4g}", fontsize=8)
    ax.set_xlabel("x")
    ax.set_ylabel("z")
    return im


def plot_fields(result: Result, path=None):
    """w and phi - phi0 at the last snapshot of a 2-D run, and max|w|(t); a failed run: at the
    last state before t* (top) and at t* (bottom)."""
    failed = result.blew_up
    fig, axes = plt.subplots(2 if failed else 1, 3, figsize=(13, 7.4 if failed else 3.8), constrained_layout=True,
                             squeeze=False)
    rows = []
    if failed:
        last = last_states_after(result, -1.0)
        if last:
            rows.append((last[-1][1], last[-1][0], result.rheology))
        elif len(result.times):
            rows.append((None, None, result.rheology))
        rows.append((result.final, result.t_star, f"{result.rheology} at t*"))
    elif len(result.times):
        rows.append((None, None, result.rheology))
    for row, (state, t, label) in zip(axes, rows):
        for ax, k in zip(row[:2], ("w", "phi")):
            fig.colorbar(field_panel(ax, result, k, len(result.times) - 1, label, state, t), ax=ax, shrink=0.8)
    if len(result.max_w_t):
        axes[0, 2].semilogy(result.max_w_t, result.max_w_series)
    axes[0, 2].set_xlabel("t")
    axes[0, 2].set_ylabel("max |w|")
    if failed:
        axes[1, 2].axis("off")
    state = f"fails at t* = {result.t_star:.4g}" if failed else "reached t_end"
    fig.suptitle(f"{result.rheology}, {result.scene}, {result.Nx}x{result.N}: {state}")
    if path:
        save_figure(fig, path, dpi=90)
    return fig


def demo_figure(mui_coarse: Result, mui_fine: Result, icidr_coarse: Result, icidr_fine: Result, path=None):
    """The paper's headline in one figure: figs 3/4(a) for mu(I), fig 6 for iCIDR."""
    fig, axes = plt.subplots(2, 2, figsize=(11, 8))
    ax = axes[0, 0]
    plot_profiles(ax, mui_fine, "w")  # linear axis: the growth before t* (the state at t* is noise)
    ax.set_title(f"(a) $\\mu(I),\\Phi(I)$, N = {mui_fine.N}: w grows in the centre (cf. fig 3a)")
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    plot_max_w(ax, mui_coarse, label=f"N = {mui_coarse.N}", color="tab:blue", ls="--")
    plot_max_w(ax, mui_fine, label=f"N = {mui_fine.N}", color="tab:red", ls="--")
    if mui_fine.blew_up:
        ax.axvline(mui_fine.t_star, color="gray", lw=0.5)
        ax.text(mui_fine.t_star, ax.get_ylim()[0] * 1.5, f" t* = {mui_fine.t_star:.4g}", fontsize=8)
    ax.set_title("(b) $\\mu(I),\\Phi(I)$ max|w|: refinement fails sooner (cf. fig 4a)")
    ax.legend(fontsize=8)
    ax = axes[1, 0]
    plot_profiles(ax, icidr_fine, "w", t_min=0.0)  # t > 0: the identical IC would dominate the panel
    plot_profiles(ax, icidr_coarse, "w", style="o", t_min=0.0)
    ax.set_title(f"(c) iCIDR w: N = {icidr_coarse.N} (o) and {icidr_fine.N} (lines) (cf. fig 6a)")
    ax.legend(fontsize=6, ncol=2)
    ax = axes[1, 1]
    plot_max_w(ax, icidr_coarse, label=f"N = {icidr_coarse.N}", color="tab:blue", marker="o",
               ls="none", mfc="none", markevery=8)
    plot_max_w(ax, icidr_fine, label=f"N = {icidr_fine.N}", color="tab:red")
    ax.set_title("(d) iCIDR max|w|: grid converged (cf. fig 6b)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    if path:
        save_figure(fig, path, dpi=120)
    return fig
