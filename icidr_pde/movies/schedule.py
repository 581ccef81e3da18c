"""The frame times of a movie: a fixed interval of simulated time, or the default schedule."""

from __future__ import annotations

import numpy as np

__all__ = ["frame_times", "MAX_FRAMES"]

DEFAULT_FRAMES = 200  # frames of the uniform part of the default schedule
DEFAULT_LOG_FRAMES = 40  # log-spaced frames before it, from t = 1e-4
MAX_FRAMES = 20_000  # 22 minutes at 15 frames/s; 96 MB of frames at N = 201


def frame_times(t_end: float, frame_dt: float | None = None) -> np.ndarray:
    """Frame times: 0, frame_dt, 2 frame_dt, ... up to t_end (t_end included).

    `frame_dt=None` (the default of ``run(movie=...)``): 40 log-spaced frames from t = 1e-4 to
    t_end/200, then every t_end/200, so that a run failing early (mu(I): t* ~ 1e-2 of t_end = 10)
    is still animated; each frame's title shows its time.
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"`t_end` must be > 0; got {t_end}")
    if frame_dt is None:
        dt = t_end / DEFAULT_FRAMES
        early = np.geomspace(min(1e-4, dt / 10), dt, DEFAULT_LOG_FRAMES + 1)[:-1]
        return np.concatenate(([0.0], early, frame_times(t_end, dt)[1:]))
    if not (np.isfinite(frame_dt) and frame_dt > 0):
        raise ValueError(f"`frame_dt` must be > 0; got {frame_dt}")
    if t_end / frame_dt > MAX_FRAMES:
        raise ValueError(f"`frame_dt` must be >= t_end/{MAX_FRAMES} = {t_end / MAX_FRAMES:g} (at most "
                         f"{MAX_FRAMES} frames, each a copy of the state); got {frame_dt:g}")
    n = int(np.floor(t_end / frame_dt * (1 + 1e-12)))
    times = frame_dt * np.arange(n + 1)
    return times if np.isclose(times[-1], t_end) else np.append(times, t_end)
