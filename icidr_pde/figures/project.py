"""The project's own figures: work-precision of every integrator, growth of the finite-volume operator."""

from __future__ import annotations

import json

import numpy as np

from .panels import pyplot
from .registry import register_figure
from .runs import DATA

__all__ = ["growth", "work_precision"]


@register_figure("work_precision", "Work-precision of every integrator and Jacobian mode (committed benchmark data)",
                 "not in the paper: python benchmarks/work_precision.py", source="data/benchmarks/work_precision.json")
def work_precision(runs):
    plt = pyplot()
    data = json.loads((DATA / "benchmarks" / "work_precision.json").read_text())
    cases = list(data["cases"])
    fig, axes = plt.subplots(1, len(cases), figsize=(6 * len(cases), 4.5), squeeze=False)
    numbers = {}
    for ax, case in zip(axes[0], cases):
        rows = [r for r in data["cases"][case]["rows"] if "error" not in r]
        for family in sorted({r["family"] for r in rows}):
            pts = sorted((r["series"], r["wall_s"]) for r in rows if r["family"] == family)
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=family)
        ax.axvline(data["cases"][case]["summary"]["target"], color="gray", lw=0.6, ls=":")
        ax.set(xlabel="max|w|(t) error (relative)", ylabel="wall time [s]", title=case)
        ax.grid(True, which="both", alpha=0.3)
        numbers[case] = data["cases"][case]["summary"].get("speedup_vs_c")
    axes[0][-1].legend(fontsize=6)
    fig.tight_layout()
    return fig, {"speedup_vs_c": numbers}


@register_figure("growth", "Largest growth rate of the linearised finite-volume operator against h (symbolic toolkit)",
                 "not in the paper: mu(I) grows like 4 Lambda_+/h^2, iCIDR stays bounded", source="stability")
def growth(runs):
    from stability.growth import fd_growth_table

    plt = pyplot()
    rows = fd_growth_table(Ns=(32, 64, 128, 256) if runs.draft else (32, 64, 128, 256, 512, 1024))
    h = np.array([r["h"] for r in rows])
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.loglog(h, [r["mui"] for r in rows], "o-", color="tab:red", label=r"$\mu(I),\Phi(I)$")
    ax.loglog(h, [max(r["icidr"], 1e-12) for r in rows], "s-", color="tab:blue", label="iCIDR (floored at 1e-12)")
    ax.invert_xaxis()
    ax.set(xlabel="grid spacing h", ylabel="max Re(eigenvalue), linearised fd operator")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig, {"rows": [{k: float(v) for k, v in r.items()} for r in rows]}
