"""py-pde trackers for shear-cell runs.

Progress bars are py-pde's own ``ProgressTracker``; snapshots use py-pde's
``MemoryStorage``/``FileStorage`` trackers. The trackers here record the derived
quantities the paper plots: max|w|(t) (figs 4a, 6b, 7e) and chi of (A18) (figs 2d, 7d).
"""

from __future__ import annotations

import numpy as np
from pde.trackers.base import TrackerBase

__all__ = ["MaxWTracker", "ChiTracker", "dense_times", "peak_abs"]


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


def peak_abs(z: np.ndarray, values: np.ndarray) -> float:
    """Peak of |values| between the nodes, from the quartic through the five nodes around
    the largest |value| (any node spacing; fewer nodes near a wall).

    Unlike the node maximum, it hardly depends on where the nodes fall relative to a sharp
    peak: for the bump of (3.16) at N = 201 the node maximum is 3e-3 low, this 5e-5.
    """
    a = np.abs(values)
    k = int(np.argmax(a))
    lo, hi = max(k - 2, 0), min(k + 3, len(a))
    if hi - lo < 3:
        return float(a[k])
    zz = z[lo:hi] - z[k]
    coeffs = np.polyfit(zz, a[lo:hi], hi - lo - 1)
    left, right = zz[max(k - 1 - lo, 0)], zz[min(k + 1 - lo, hi - lo - 1)]
    roots = np.roots(np.polyder(coeffs))
    roots = roots[np.isreal(roots)].real
    candidates = np.concatenate(([left, right], roots[(roots > left) & (roots < right)]))
    return float(max(a[k], np.polyval(coeffs, candidates).max()))


class MaxWTracker(TrackerBase):
    """Record max|w|(t) at the interrupts: over the nodes, and as a sub-node peak.

    Args:
        interrupts: when to record (py-pde interrupt data, e.g. a list of times)
        z: node positions for the sub-node peak (default: the grid's cell centres)
    """

    name = "max_w"

    def __init__(self, interrupts=1, z: np.ndarray | None = None):
        super().__init__(interrupts=interrupts)
        self.z = z
        self.times: list[float] = []
        self.values: list[float] = []
        self.peaks: list[float] = []

    def handle(self, field, t: float) -> None:
        w = field.data[2]
        z = field.grid.axes_coords[0] if self.z is None else self.z
        self.times.append(float(t))
        self.values.append(float(np.max(np.abs(w))))
        self.peaks.append(peak_abs(z, w))


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
