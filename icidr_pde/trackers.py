"""py-pde trackers for shear-cell runs.

Progress bars are py-pde's own ``ProgressTracker``; snapshots use py-pde's
``MemoryStorage``/``FileStorage`` trackers. The trackers here record the derived
quantities the paper plots: max|w|(t) (figs 4a, 6b, 7e) and chi of (A18) (figs 2d, 7d).
"""

from __future__ import annotations

import numpy as np
from pde.trackers.base import TrackerBase

__all__ = ["MaxWTracker", "ChiTracker", "dense_times"]


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


class MaxWTracker(TrackerBase):
    """Record max|w|(t), the maximum over the nodes, at the interrupts.

    Args:
        interrupts: when to record (py-pde interrupt data, e.g. a list of times)
    """

    name = "max_w"

    def __init__(self, interrupts=1):
        super().__init__(interrupts=interrupts)
        self.times: list[float] = []
        self.values: list[float] = []

    def handle(self, field, t: float) -> None:
        self.times.append(float(t))
        self.values.append(float(np.max(np.abs(field.data[2]))))


class ChiTracker(TrackerBase):
    """Record chi of (A18) where the stresses are evaluated (chi > 0: mu(I) ill-posed).

    Args:
        pde: the shear-cell PDE (supplies the strain rates of its discretization)
        interrupts: when to record
    """

    name = "chi"

    def __init__(self, pde, interrupts=1):
        super().__init__(interrupts=interrupts)
        self.pde = pde
        self.times: list[float] = []
        self.z: np.ndarray | None = None
        self.values: list[np.ndarray] = []

    def handle(self, field, t: float) -> None:
        z, phi, uz, wz = self.pde.strain_rates(field.data, field.grid)
        self.z = z
        self.times.append(float(t))
        self.values.append(self.pde.rheology.chi(phi, uz, wz))
