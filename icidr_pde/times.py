"""Output times of a run: the dense max|w| series and the requested snapshot times.

Plain numpy (no py-pde), so that every run path, including the native engine's, uses the
same times.
"""

from __future__ import annotations

import numpy as np

from .validation import ParameterError, real, shown

__all__ = ["dense_times", "time_labels", "time_tolerance", "check_t_end", "MIN_T_END", "MAX_T_END", "chi_times",
           "merged_output_times"]

#: the largest t_end: beyond it the round-off of the rates at the steady state, integrated over
#: t, drifts the conserved mass of phi (measured, native engine, iCIDR shear and sine, fd N = 201:
#: |drift| <= 3e-16 up to t_end = 1e16, then proportional to t_end: 2e-14 at 1e20, 1e-9 at 1e25,
#: 1e-4 at 1e30, 5e-2 at 1e40); nothing of the shear cell happens after t ~ 1e3
MAX_T_END = 1e15
#: the smallest t_end: output times closer than :func:`time_tolerance` (0) = 1e-8 to t = 0 are the
#: initial time, so a shorter run has no output time and no final state
MIN_T_END = 1e-8


def check_t_end(t_end) -> float:
    """t_end as a float in [:data:`MIN_T_END`, :data:`MAX_T_END`], refused with the reason outside."""
    t_end = real("t_end", t_end, 0)
    wanted = f"`t_end` must be a finite number in [{MIN_T_END:g}, {MAX_T_END:g}]; got {shown(t_end)}"
    if t_end < MIN_T_END:
        raise ParameterError(f"{wanted} (output times within {MIN_T_END:g} of 0 are the initial time: "
                             "a shorter run has no output)")
    if t_end > MAX_T_END:
        raise ParameterError(f"{wanted} (beyond {MAX_T_END:g} the round-off of the rates, integrated "
                             "over t, drifts the mass of phi)")
    return t_end


def time_tolerance(t) -> float:
    """Output times closer than this to t are one time: py-pde's absolute 1e-8 where float
    numbers resolve it, else 16 spacings of the float numbers at t (an absolute 1e-8 vanishes
    in t + 1e-8 once t > 2**28, and a recorder waiting for t to pass it would wait forever)."""
    return max(1e-8, 16.0 * float(np.spacing(abs(float(t)))))


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
        if not (np.isfinite(value) and 0 <= value <= t_end):  # a number: say which end it is beyond
            where = f" (> t_end = {t_end:g})" if value > t_end else " (< 0)" if value < 0 else ""
            raise ParameterError(f"`times` must be {wanted}; got {value:g}{where}")
        labels.append(t if isinstance(t, str) else f"{value:g}")
        values.append(value)
    order = np.argsort(values, kind="stable")
    return [labels[i] for i in order], np.array(values)[order]


def chi_times(t_end: float) -> np.ndarray:
    """When chi of (A18) is sampled: 0 and 20 log-spaced times up to t_end (a diagnostic)."""
    return np.unique(np.concatenate(([0.0], np.geomspace(min(1e-3, t_end / 10), t_end, 20))))


def merged_output_times(t_end, lists):
    """Merged output times (> 0, increasing; times within :func:`time_tolerance` are one
    output, as the stiff solver's recorders) and, per list, the output index of each of its
    times (-1: at t = 0)."""
    every = np.sort(np.concatenate([np.asarray(t, float) for t in lists] + [[t_end]]))
    merged = []
    for t in every:
        if t < time_tolerance(0.0):
            continue
        if not merged or t >= merged[-1] + time_tolerance(merged[-1]):
            merged.append(float(t))
    merged = np.array(merged)
    where = []
    for times in lists:
        times = np.asarray(times, float)
        tolerance = np.array([time_tolerance(t) for t in times])
        index = np.searchsorted(merged, times - tolerance, side="left")
        index[times < time_tolerance(0.0)] = -1
        where.append(index)
    return merged, where
