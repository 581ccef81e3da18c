"""The figures of a movie, updated frame by frame: phi, u, w against z and max|w|(t) of one 1-D
run (:func:`write_movie`, :func:`movie_from_result`); w and phi - phi0 over the cell of 2-D runs
side by side (:func:`write_field_movie`, :func:`movie_from_results_2d`). The frames go to
:mod:`.sink`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..progress import short_reason
from .sink import movie_target, write_frames

__all__ = ["write_movie", "movie_from_result", "write_field_movie", "movie_from_results_2d"]


class _FrameFigure:
    """One figure (phi, u, w, max|w|(t)) whose artists are updated for every frame."""

    def __init__(self, z, times, frames, max_w_t, max_w, title, dpi):
        from matplotlib.figure import Figure
        from matplotlib.ticker import LogFormatter

        self.fig = Figure(figsize=(12, 3.4), dpi=dpi)
        axes = self.fig.subplots(1, 4)
        steady = np.array(frames[0]) if len(frames) else None
        self.lines = []
        regular = frames[:-1] if len(frames) > 2 else frames  # axis limits without the t* state
        for k, (ax, name) in enumerate(zip(axes, ("φ", "u", "w"))):
            ax.plot(z, steady[k], color="k", ls="--", lw=0.8, label="t = 0")
            (line,) = ax.plot(z, steady[k], color="tab:red")
            self.lines.append(line)
            lo, hi = np.min(regular[:, k]), np.max(regular[:, k])
            pad = 0.05 * (hi - lo) if hi > lo else 1e-3 * max(abs(hi), 1.0)
            ax.set_ylim(lo - pad, hi + pad)
            ax.set_xlabel("z")
            ax.set_ylabel(name)
        ax = axes[3]
        keep = max_w_t > 0
        ax.loglog(max_w_t[keep], max_w[keep], color="0.6", lw=1)
        (self.marker,) = ax.loglog([], [], "o", color="tab:red")
        for axis in (ax.xaxis, ax.yaxis):  # plain "1e-2" labels: mathtext would double the drawing time
            axis.set_major_formatter(LogFormatter(labelOnlyBase=True))
            axis.set_minor_formatter(LogFormatter(labelOnlyBase=True))
        ax.set_xlabel("t")
        ax.set_ylabel("max|w|")
        self.axes = axes
        self.max_w_t, self.max_w = max_w_t, max_w
        self.title = title
        self.suptitle = self.fig.suptitle(title)
        self.fig.tight_layout()
        #: what changes from frame to frame (drawn on the kept background)
        self.animated = [*self.lines, self.marker, self.suptitle]

    def update(self, t, frame, note="") -> bool:
        """Show frame `frame` at time `t`; True where the axes changed (draw all anew)."""
        for k, line in enumerate(self.lines):
            line.set_ydata(frame[k])
        if note:  # the failure state: its values can be far outside the regular frames
            for k, ax in enumerate(self.axes[:3]):
                ax.relim()
                ax.autoscale(axis="y")  # on again: the limits of the regular frames were set by hand
        if t > 0:
            self.marker.set_data([t], [np.interp(t, self.max_w_t, self.max_w)])
        self.suptitle.set_text(f"{self.title}    t = {t:.4g}{note}")
        return bool(note)


def write_movie(path, z, times, frames, *, max_w_t=None, max_w=None, title="", failed_reason=None,
                fps: float = 15, dpi: int = 100, progress: bool = False) -> Path:
    """Write frames (array (n, 3, len(z)) of phi, u, w at `times`) as a movie at `path`.

    `failed_reason`: the last frame is the state at t* of a failed run (titled so).
    The suffix of `path` picks the format: .mp4 (ffmpeg) or .gif (Pillow). Returns the
    path written, which is a .gif beside `path` when an .mp4 was asked for but no
    ffmpeg exists (with a warning). `progress`: a tqdm bar counting the frames written.
    """
    path = Path(path)
    frames = np.asarray(frames, dtype=float)
    times = np.asarray(times, dtype=float)
    if frames.ndim != 3 or frames.shape[0] != len(times) or frames.shape[1] != 3 or len(times) == 0:
        raise ValueError(f"`frames` must have shape (n_times, 3, n_z) with n_times = {len(times)} > 0; "
                         f"got {frames.shape}")
    path, suffix = movie_target(path)
    if max_w_t is None:
        max_w_t, max_w = times, np.max(np.abs(frames[:, 2]), axis=1)
    plot = _FrameFigure(z, times, frames, np.asarray(max_w_t, float), np.asarray(max_w, float), title, dpi)
    return write_frames(plot.fig, path, suffix, fps, lambda grab: _add_frames(plot, times, frames, failed_reason, grab),
                        animated=plot.animated, n_frames=len(times), progress=progress)


def _add_frames(plot, times, frames, failed_reason, grab):
    last = len(times) - 1
    for k, (t, frame) in enumerate(zip(times, frames)):
        note = f"  FAILED at t* ({short_reason(failed_reason)})" if failed_reason and k == last else ""
        grab(plot.fig, plot.update(t, frame, note))


def movie_from_result(result, path, *, frame_dt=None, title=None, **kwargs) -> Path:
    """Movie of a :class:`~icidr_pde.result.Result`'s snapshots (plus its state at t* if it failed).

    `frame_dt`: keep only the snapshots at multiples of it (the run may hold others).
    """
    times, frames = np.asarray(result.times), np.stack([result.phi, result.u, result.w], axis=1)
    if frame_dt is not None:
        k = times / frame_dt
        keep = np.abs(k - np.round(k)) < 1e-6
        times, frames = times[keep], frames[keep]
    reason = None
    if result.blew_up:
        times = np.append(times, result.t_star)
        frames = np.concatenate([frames, np.asarray(result.final)[None]], axis=0)
        reason = result.reason
    if title is None:
        title = f"{result.rheology}, scene {result.scene}, {result.discretization} N = {result.N}"
    return write_movie(path, result.z, times, frames, max_w_t=result.max_w_t, max_w=result.max_w_series,
                       title=title, failed_reason=reason, **kwargs)


class _FieldFrameFigure:
    """w and phi - phi0 of two 2-D runs side by side, with max|w|(t) and max|phi - phi0|(t) of both.

    Colour scales are symmetric and set per frame (a blow-up spans decades); each panel's title
    gives its maximum.
    """

    def __init__(self, extent, labels, first, series, title, dpi):
        from matplotlib.figure import Figure
        from matplotlib.ticker import LogFormatter

        self.fig = Figure(figsize=(13, 6.8), dpi=dpi)  # a fixed layout: re-laying out every frame is slow
        axes = self.fig.subplots(2, 3, gridspec_kw=dict(left=0.05, right=0.98, bottom=0.08, top=0.9, wspace=0.5,
                                                         hspace=0.3))
        self.labels, self.images, self.bars = labels, {}, {}
        for col, label in enumerate(labels):
            for row, name in enumerate(("w", "φ − φ0")):
                ax = axes[row, col]
                im = ax.imshow(first[label][row].T, origin="lower", extent=extent, cmap="RdBu_r",
                               interpolation="nearest")
                self.images[label, row] = im
                self.bars[label, row] = self.fig.colorbar(im, ax=ax, shrink=0.85)
                ax.set_xlabel("x")
                ax.set_ylabel("z")
        self.axes = axes
        self.markers = {}
        for row, name in enumerate(("max|w|", "max|φ − φ0|")):
            ax = axes[row, 2]
            for k, label in enumerate(labels):
                t, v = series[label][row]
                color = ("tab:red", "tab:blue")[k % 2]
                ax.semilogy(t, v, color=color, lw=1, label=label)
                (self.markers[label, row],) = ax.semilogy([], [], "o", color=color, clip_on=False)
            if row == 0:  # a failed run's max|w| at t* (1e6-1e10) would flatten everything else
                ax.set_ylim(top=2.0)
            ax.yaxis.set_major_formatter(LogFormatter(labelOnlyBase=True))  # plain "1e-2": mathtext slows every frame
            ax.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=True))
            ax.set_xlabel("t")
            ax.set_ylabel(name)
            ax.legend(fontsize=7, loc="upper left")
        self.series = series
        self.title = title
        self.suptitle = self.fig.suptitle(title, fontsize=10)

    def update(self, t, fields, note=""):
        for label in self.labels:
            for row, name in enumerate(("w", "φ − φ0")):
                data = fields[label][row]
                vmax = float(np.max(np.abs(data))) or 1e-12
                im = self.images[label, row]
                im.set_data(data.T)
                im.set_clim(-vmax, vmax)
                self.axes[row, self.labels.index(label)].set_title(
                    f"{label}: {name}  (max {vmax:.2g})", fontsize=8)
                ymax = self.axes[row, 2].get_ylim()[1]  # the state at t* is far off the axis: the marker sits at its top
                self.markers[label, row].set_data([t], [min(vmax, ymax)])  # this frame's own maximum
        self.suptitle.set_text(f"{self.title}    t = {t:.4g}{note}")


def write_field_movie(path, extent, times, frames: dict, *, series: dict | None = None, title: str = "",
                      last_note: str = "", fps: float = 10, dpi: int = 90, progress: bool = True) -> Path:
    """Write a movie of two (or more) 2-D runs side by side at `path` (.mp4 through ffmpeg, or .gif).

    `frames`: {label: array (n_times, 2, Nx, Nz) of w and phi - phi0 at `times`}; `series`:
    {label: ((t, max|w|), (t, max|phi - phi0|))} for the right-hand column (default: from the frames);
    `last_note` is appended to the title of the last frame (a failed run's state at t*).
    `progress`: a tqdm bar counting the frames written (its total is the number of frames).
    Written to a temporary name and renamed when complete.
    """
    path = Path(path)
    times = np.asarray(times, dtype=float)
    frames = {label: np.asarray(f, dtype=float) for label, f in frames.items()}
    if not frames or any(f.ndim != 4 or f.shape[:2] != (len(times), 2) for f in frames.values()) or len(times) == 0:
        raise ValueError(f"`frames` must map labels to arrays of shape (n_times, 2, Nx, Nz) with n_times = "
                         f"{len(times)} > 0; got {({k: v.shape for k, v in frames.items()})}")
    path, suffix = movie_target(path)
    if series is None:
        series = {label: tuple((times, np.max(np.abs(f[:, row]), axis=(1, 2))) for row in (0, 1))
                  for label, f in frames.items()}
    labels = list(frames)
    plot = _FieldFrameFigure(extent, labels, {k: v[0] for k, v in frames.items()}, series, title, dpi)
    # every frame is drawn in full: its colour scales, colour bars and titles change
    return write_frames(plot.fig, path, suffix, fps, lambda grab: _add_field_frames(plot, times, frames, last_note, grab),
                        n_frames=len(times), progress=progress)


def _add_field_frames(plot, times, frames, last_note, grab):
    last = len(times) - 1
    for k, t in enumerate(times):
        plot.update(t, {label: f[k] for label, f in frames.items()}, last_note if k == last else "")
        grab(plot.fig)


def movie_from_results_2d(results: dict, path, *, title: str = "", stride: int = 1, **kwargs) -> Path:
    """Movie of 2-D runs side by side ({label: Result}) at the snapshot times of the first.

    Every other run must hold snapshots at those times. If the first run failed, a last frame
    shows its state at t* beside the others' snapshot at t* (titled with the reason).
    `stride`: keep every stride-th snapshot (the last one and the failure frame always).
    Other keyword arguments go to :func:`write_field_movie` (fps, dpi, progress).
    """
    if not (isinstance(stride, int) and stride >= 1):
        raise ValueError(f"`stride` must be an integer >= 1; got {stride!r}")
    labels = list(results)
    first = results[labels[0]]
    times = np.asarray(first.times, dtype=float)
    times = times[sorted(set(range(0, len(times), stride)) | {len(times) - 1})]

    def fields(res, k):
        return np.stack([res.w[k], res.phi[k] - res.scene_params["phi0"]])

    def index(res, t):
        k = int(np.argmin(np.abs(np.asarray(res.times) - t)))
        if abs(res.times[k] - t) > 1e-6 * max(1.0, abs(t)):
            raise ValueError(f"`results`: {res.rheology} has no snapshot at t = {t:g} (nearest {res.times[k]:g})")
        return k

    frames = {label: np.stack([fields(res, index(res, t)) for t in times]) for label, res in results.items()}
    note = ""
    if first.blew_up:
        final = np.asarray(first.final)
        frames[labels[0]] = np.concatenate([frames[labels[0]], np.stack([final[2], final[0] - first.scene_params["phi0"]])[None]])
        for label in labels[1:]:
            res = results[label]
            frames[label] = np.concatenate([frames[label], fields(res, index(res, first.t_star))[None]])
        times = np.append(times, first.t_star)
        note = f"  {labels[0]} FAILED at t* ({first.reason.split(' (')[0]})"
    series = {}
    for label, res in results.items():  # right-hand column: every snapshot up to the last frame, not only the frames
        keep = np.asarray(res.max_w_t) <= times[-1] * (1 + 1e-9)
        snap = np.asarray(res.times) <= times[-1] * (1 + 1e-9)
        t_phi = np.asarray(res.times)[snap]
        phi_dev = np.max(np.abs(np.asarray(res.phi)[snap] - res.scene_params["phi0"]), axis=(1, 2))
        if res is first and first.blew_up:
            t_phi, phi_dev = np.append(t_phi, times[-1]), np.append(phi_dev, np.max(np.abs(frames[label][-1, 1])))
        series[label] = ((np.asarray(res.max_w_t)[keep], np.asarray(res.max_w_series)[keep]), (t_phi, phi_dev))
    L, H = first.scene_params["L"], first.scene_params["H"]
    return write_field_movie(path, (0.0, L, 0.0, H), times, frames, series=series, title=title, last_note=note,
                             **kwargs)
