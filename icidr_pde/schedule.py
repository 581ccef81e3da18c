"""The schedule of a run: the times at which every engine hands its state to the run path.

Snapshot times and their labels, the max|w| series and the chi samples of (A18); the drive loop
(:mod:`icidr_pde.drive`) merges them with the recorders' times into one list of outputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .times import chi_times, dense_times, time_labels

__all__ = ["Schedule", "schedule"]


@dataclass
class Schedule:
    """The output times of a run, for every engine: snapshot `labels` and `snap_times`, the
    max|w| series `series` and the chi samples `chi_times` (empty: none)."""

    labels: list
    snap_times: np.ndarray
    series: np.ndarray
    chi_times: np.ndarray


def schedule(scene, t_end: float, times=None, *, series_times=None, chi: bool | None = None) -> Schedule:
    """Snapshots at `times` (default: the scene's), max|w| at `series_times` (default dense;
    empty: none), chi of (A18) if the scene asks for it (or `chi`)."""
    if times is None:
        times = [t for t in scene.default_times if t <= t_end] + [t_end]
    labels, snap_times = time_labels(times, t_end)
    series = dense_times(t_end) if series_times is None else np.sort(np.asarray(series_times, float))
    with_chi = chi or (chi is None and "chi" in scene.outputs)
    return Schedule(labels, snap_times, series, chi_times(t_end) if with_chi else np.empty(0))
