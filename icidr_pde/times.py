"""Output times of a run: the dense max|w| series and the requested snapshot times.

Plain numpy (no py-pde), so that every run path, including the native engine's, uses the
same times.
"""

from __future__ import annotations

import numpy as np

from .validation import ParameterError, real, shown

__all__ = ["dense_times", "time_labels"]


def dense_times(t_end: float, n_log: int = 120, n_lin: int = 400, t_min: float = 1e-4) -> np.ndarray:
    """Interrupt times for time series: log-spaced from `t_min` plus uniform, up to t_end.

    The log part resolves early failures (t* ~ 1e-2 for mu(I)); the uniform part the
    decay to steady state.
    """
    if not t_end > 0:
        raise ValueError(f"`t_end` must be > 0; got {t_end}")
    t_min = min(t_min, t_end / 10)
    times = np.concatenate(([0.0], np.geomspace(t_min, t_end, n_log), np.linspace(0, t_end, n_lin)))
    return np.unique(times)


def time_labels(times, t_end):
    """(labels, values) of the snapshot times `times` in [0, t_end], sorted by value; a
    string keeps its spelling as the label."""
    labels, values = [], []
    wanted = f"numbers in [0, t_end] = [0, {t_end:g}]"
    if isinstance(times, (str, bytes)) or not np.iterable(times):
        raise ParameterError(f"`times` must be a list of {wanted}; got {shown(times)}")
    for t in times:
        try:
            value = float(t) if isinstance(t, str) else real("times", t)
        except (ValueError, TypeError):
            raise ParameterError(f"`times` must be {wanted}; got {shown(t)}") from None
        if not (np.isfinite(value) and 0 <= value <= t_end):
            raise ParameterError(f"`times` must be {wanted}; got {shown(t)}")
        labels.append(t if isinstance(t, str) else f"{value:g}")
        values.append(value)
    order = np.argsort(values, kind="stable")
    return [labels[i] for i in order], np.array(values)[order]
