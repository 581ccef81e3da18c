"""Fig 4(b): the failure time t* against N (``icidr-pde tstar --plot``)."""

from __future__ import annotations

from ..outputs import save_figure
from ..studies.failure_time import PAPER_TSTAR, threshold

__all__ = ["plot_tstar"]


def plot_tstar(curves: dict[str, dict], path: str, *, title: str | None = None,
               t_end: float | None = None, paper: bool = True, settings: dict[str, str] | None = None) -> None:
    """Fig 4(b): t* against N, one curve per label; runs without failure marked at the bottom.
    `settings` ({label: text}) says in the legend how a curve was computed (a t* is quoted with its
    integrator and tolerances)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    styles = {"cheb": dict(color="C3", marker="o", ls="-"), "fd": dict(color="C0", marker="s", ls="--")}
    from ..discretizations import DISCRETIZATIONS

    names = {name: cls.label for name, cls in DISCRETIZATIONS.items()}
    all_t = [t for m in curves.values() for t in m.values() if t is not None]
    floor = min(all_t) / 2 if all_t else 1e-3
    for k, (label, mapping) in enumerate(curves.items()):
        items = sorted((int(n), t) for n, t in mapping.items())
        style = styles.get(label, dict(color=f"C{k + 4}", marker="^", ls="-"))
        n_f = [n for n, t in items if t is not None]
        t_f = [t for n, t in items if t is not None]
        thr = threshold(mapping)
        extra = f", all fail for N >= {thr}" if thr is not None else ""
        if settings and settings.get(label):
            extra += f"\n({settings[label]})"
        ax.plot(n_f, t_f, ms=3, lw=1, label=f"{names.get(label, label)}{extra}", **style)
        n_ok = [n for n, t in items if t is None]
        if n_ok:
            ax.plot(n_ok, [floor * 1.15**k] * len(n_ok), ls="none", marker="v", mfc="none",
                    color=style["color"], ms=5,
                    label=f"{names.get(label, label)}: no failure" + (f" by t = {t_end:g}" if t_end else ""))
    if paper:
        ax.plot([PAPER_TSTAR["N"]], [PAPER_TSTAR["t_star"]], marker="*", ms=13, ls="none",
                color="k", label=f"paper: t* = {PAPER_TSTAR['t_star']} (Chebyshev N = 201)")
    ax.set_yscale("log")
    ax.set_xlabel(r"$N_z$")
    ax.set_ylabel(r"$\hat t_*$")
    ax.set_title(title or r"$\mu(I),\Phi(I)$, IC (3.16): failure time (fig 4b)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path, dpi=130)
    plt.close(fig)
