"""The field images and the movie of docs/sim2d.md (scene bump2d, both rheologies).

``icidr-pde figures sim2d-fields [--out DIR] [--N N] [--movie-N N] [--frames K]`` writes
DIR/sim2d_fields.png (w and phi - phi0 of both rheologies) and DIR/sim2d.mp4 (both runs side by
side, through :func:`icidr_pde.movies.render.movie_from_results_2d`), from runs with the settings of
:mod:`icidr_pde.studies.sim2d`. DIR defaults to ``docs``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs import save_figure
from ..plotting import field_panel
from ..studies.sim2d import SETTINGS

__all__ = ["field_figure", "movie"]


def _failure_time(n: int, t_end: float = 10.0) -> float:
    """mu(I)'s t* on bump2d at n x n (t_end where it does not fail)."""
    from ..api import run

    probe = run("mui", "bump2d", (n, n), t_end, ["0", f"{t_end:g}"], series_times=[], **SETTINGS)
    return probe.t_star if probe.blew_up else t_end


def _snapshots(rheology, n, t_end, n_frames):
    from ..api import run

    t_end = float(f"{t_end:.4g}")  # the labels below must not round past t_end
    times = [f"{t:.6g}" for t in np.linspace(0.0, t_end, n_frames)[:-1]] + [f"{t_end:.6g}"]
    return run(rheology, "bump2d", (n, n), t_end, times, **SETTINGS)


def field_figure(path="docs/sim2d_fields.png", n=64) -> Path:
    """w and phi - phi0 of both rheologies on bump2d: iCIDR at t = 0.5, 2, 10, mu(I) before t*."""
    import matplotlib.pyplot as plt

    from ..api import run

    icidr = run("icidr", "bump2d", (n, n), 10.0, ["0.5", "2", "10"], series_times=[], **SETTINGS)
    t_star = _failure_time(n)
    mui = run("mui", "bump2d", (n, n), 10.0, [f"{f * t_star:.6g}" for f in (0.25, 0.6, 0.97)],
              series_times=[], **SETTINGS)
    fig, axes = plt.subplots(4, 3, figsize=(10, 12), constrained_layout=True)
    for row, (res, k, label) in enumerate(((icidr, "w", "iCIDR"), (icidr, "phi", "iCIDR"),
                                           (mui, "w", "mu(I)"), (mui, "phi", "mu(I)"))):
        for col in range(3):
            if col < len(res.times):
                im = field_panel(axes[row, col], res, k, col, label)
                fig.colorbar(im, ax=axes[row, col], shrink=0.8)
    fig.suptitle(f"bump2d, {n}x{n}: iCIDR decays smoothly; mu(I),Phi(I) fails at t* = {t_star:.3g}")
    save_figure(fig, path, dpi=90)
    plt.close(fig)
    return Path(path)


def movie(path="docs/sim2d.mp4", n=48, n_frames=60, progress=True) -> Path:
    """Movie of w and phi - phi0, iCIDR and mu(I),Phi(I) side by side, the same n_frames
    snapshots up to 0.99 t* of mu(I) (its failure frame last), with max|w| against t beside."""
    from ..movies.render import movie_from_results_2d

    t_star = _failure_time(n)
    mui = _snapshots("mui", n, 0.99 * t_star, n_frames)
    icidr = _snapshots("icidr", n, 0.99 * t_star, n_frames)
    return movie_from_results_2d({"mu(I)": mui, "iCIDR": icidr}, path, fps=12,
                                 title=f"bump2d, {n}x{n}: mu(I),Phi(I) fails at t* = {t_star:.3g}, iCIDR decays", progress=progress)
