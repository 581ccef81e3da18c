"""What several figures draw or measure: chi > 0 intervals, sign changes, snapshots at a time,
max|w| extrema, grid differences, colours and labels."""

from __future__ import annotations

import numpy as np

__all__ = ["chi_infinite_z", "grid_difference", "grid_pair", "line_colors", "max_w_extrema", "max_w_pair",
           "positive_intervals", "pyplot", "scheme_label", "sign_changes", "snapshot_at", "tstar_label"]


def pyplot():
    import matplotlib.pyplot as plt

    return plt


def positive_intervals(z, values) -> list[list[float]]:
    """The z-intervals where `values` > 0 (each [first z, last z] of a run of positive values)."""
    positive = np.asarray(values) > 0
    intervals, start = [], None
    for k, flag in enumerate(positive):
        if flag and start is None:
            start = k
        if start is not None and (not flag or k == len(positive) - 1):
            stop = k if flag else k - 1
            intervals.append([float(z[start]), float(z[stop])])
            start = None
    return intervals


def sign_changes(x, y) -> list[float]:
    """The zeros of the piecewise-linear interpolant of y(x): each x where y is 0 at a node, and
    x0 - y0 (x1 - x0) / (y1 - y0) between neighbours x0, x1 where y changes sign."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    k = np.nonzero(y[:-1] * y[1:] < 0)[0]
    between = x[k] - y[k] * (x[k + 1] - x[k]) / (y[k + 1] - y[k])
    return sorted(float(r) for r in np.concatenate([x[y == 0], between]))


def chi_infinite_z(result, k=0) -> list[float]:
    """Where chi (A18) of snapshot `k` is infinite: its denominator |u_z| vanishes where u_z, the
    face gradient of u (finite volumes: (u_i+1 - u_i) / (z_i+1 - z_i) at the face between), changes
    sign; located between faces by linear interpolation. On no node is chi exactly infinite."""
    z, u = np.asarray(result.z), np.asarray(result.u[k])
    return sign_changes(0.5 * (z[1:] + z[:-1]), np.diff(u) / np.diff(z))


def snapshot_at(result, t):
    """Index of the snapshot at time t (exact match of a requested time)."""
    k = int(np.argmin(np.abs(result.times - t)))
    if abs(result.times[k] - t) > 1e-9:
        raise KeyError(f"no snapshot at t = {t} in {result.rheology} N = {result.N}")
    return k


def line_colors(n):
    return pyplot().cm.viridis(np.linspace(0, 0.85, max(n, 1)))


def scheme_label(result) -> str:
    """The discretization's name in labels ("finite volumes", "Chebyshev")."""
    from ..discretizations import DISCRETIZATIONS

    return DISCRETIZATIONS[result.discretization].label


def tstar_label(result):
    return f"t* = {result.t_star:.5g}" if result.blew_up else "no failure"


def max_w_extrema(result, t_min=0.0):
    """Global maximum of max|w|(t) and the interior local maxima after t_min."""
    t, m = result.max_w_t, result.max_w_series
    keep = t >= t_min
    t, m = t[keep], m[keep]
    inner = [k for k in range(1, len(m) - 1) if m[k] >= m[k - 1] and m[k] > m[k + 1]]
    return {"max": float(m.max()), "t_of_max": float(t[np.argmax(m)]),
            "local_maxima": [[float(t[k]), float(m[k])] for k in inner],
            "final": float(m[-1]), "t_final": float(t[-1])}


def grid_difference(coarse, fine, times):
    """Largest |w_coarse - w_fine| (fine interpolated to the coarse nodes) over the snapshot `times`
    after t = 0 (at t = 0 both are the same formula; the difference would be interpolation error)."""
    return max(float(np.max(np.abs(np.interp(coarse.z, fine.z, fine.w[snapshot_at(fine, t)])
                                   - coarse.w[snapshot_at(coarse, t)]))) for t in times if t > 0)


def grid_pair(ax, coarse, fine, field, times, ms):
    """Snapshots of `field` at `times`: the fine run as lines, the coarse one as open circles (figs 6, 7)."""
    for t, c in zip(times, line_colors(len(times))):
        ax.plot(fine.z, getattr(fine, field)[snapshot_at(fine, t)], color=c, label=f"t = {t:g}")
        ax.plot(coarse.z, getattr(coarse, field)[snapshot_at(coarse, t)], "o", color=c, mfc="none", ms=ms)


def max_w_pair(ax, coarse, fine, ms):
    """max|w|(t) of the coarse run (open circles) and the fine one (a red line) (figs 6, 7)."""
    ax.plot(coarse.max_w_t, coarse.max_w_series, "o", color="tab:blue", mfc="none", ms=ms, markevery=6,
            label=f"N = {coarse.N}")
    ax.plot(fine.max_w_t, fine.max_w_series, color="tab:red", label=f"N = {fine.N}")
