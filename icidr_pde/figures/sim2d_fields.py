"""The field images and the movie of docs/sim2d.md (scene bump2d, both rheologies).

``python -m icidr_pde.figures.sim2d_fields`` writes docs/sim2d_fields.png (w and phi - phi0 of both
rheologies) and docs/sim2d.mp4 (w of both runs side by side), from runs with the settings of
:mod:`icidr_pde.studies.sim2d`.
"""

from __future__ import annotations

import sys

import numpy as np

from ..outputs import replacing, save_figure
from ..plotting import field_panel
from ..studies.sim2d import SETTINGS

__all__ = ["field_figure", "movie"]


def _snapshots(rheology, n, t_end, n_frames):
    from ..api import run

    t_end = float(f"{t_end:.4g}")  # the labels below must not round past t_end
    times = [f"{t:.6g}" for t in np.linspace(0.0, t_end, n_frames)[:-1]] + [f"{t_end:.6g}"]
    return run(rheology, "bump2d", (n, n), t_end, times, series_times=[], **SETTINGS)


def field_figure(path="docs/sim2d_fields.png", n=64) -> None:
    """w and phi - phi0 of both rheologies on bump2d: iCIDR at t = 0.5, 2, 10, mu(I) before t*."""
    import matplotlib.pyplot as plt

    from ..api import run

    icidr = run("icidr", "bump2d", (n, n), 10.0, ["0.5", "2", "10"], series_times=[], **SETTINGS)
    probe = run("mui", "bump2d", (n, n), 10.0, ["0", "10"], series_times=[], **SETTINGS)
    t_star = probe.t_star if probe.blew_up else 10.0
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
    print(f"figure written to {path}")


def movie(path="docs/sim2d.mp4", n=48, n_frames=60) -> None:
    """Side-by-side movie of w: iCIDR to t = 10 and mu(I),Phi(I) up to its failure, same frame count."""
    import imageio_ffmpeg
    import matplotlib
    import matplotlib.animation as animation
    import matplotlib.pyplot as plt

    from ..api import run

    matplotlib.rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
    icidr = _snapshots("icidr", n, 10.0, n_frames)
    probe = run("mui", "bump2d", (n, n), 10.0, ["0", "10"], series_times=[], **SETTINGS)
    t_star = probe.t_star if probe.blew_up else 10.0
    mui = _snapshots("mui", n, 0.99 * t_star, n_frames)
    fig, axes = plt.subplots(1, 2, figsize=(9, 4.2), constrained_layout=True)

    def draw(frame):
        for ax in axes:
            ax.clear()
        field_panel(axes[0], icidr, "w", min(frame, len(icidr.times) - 1), "iCIDR")
        field_panel(axes[1], mui, "w", min(frame, len(mui.times) - 1), "mu(I)")

    anim = animation.FuncAnimation(fig, draw, frames=n_frames)
    with replacing(path) as tmp:
        anim.save(tmp, writer=animation.FFMpegWriter(fps=12, bitrate=900))
    plt.close(fig)
    print(f"movie written to {path}")


def main() -> int:
    field_figure()
    movie()
    return 0


if __name__ == "__main__":
    sys.exit(main())
