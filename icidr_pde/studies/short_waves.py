"""The growth rates of a 2-D run's x-waves: what an amplifying time integration would show first.

For a field f(x, z) of the x-periodic cell (snapshots of shape (times, Nx, Nz)), the amplitude of
x-wave number k (k wavelengths in the period L) over the rows `rows` of z is

    a_k(t) = || rfft_x(f - <f>_x)[k, rows] ||_2,

and its growth rate between the first and last snapshot log(a_k(t1) / a_k(t0)) / (t1 - t0).
The continuum damps every x-wave of iCIDR at about -0.03 (issue 37; :mod:`stability.linear2d`): a
positive rate at large k is the discretization or the integrator. Waves whose amplitude at t0 is at
round-off (below ``floor`` times the largest amplitude) have no measurable rate and are left out.
"""

from __future__ import annotations

import numpy as np

__all__ = ["amplitudes", "growth_rates", "wall_rows", "ROUND_OFF_FLOOR", "SHORT"]

#: a wave below this fraction of the field's largest x-wave amplitude is at round-off: no rate
ROUND_OFF_FLOOR = 1e-11
#: the short x-waves of bump2d (L = 30): k >= 24 wavelengths in the period. The bump's own waves
#: (k <= 16) exchange amplitude between phi and w and spread toward the walls, so their rates over
#: one field or one region are not the eigen-rates of the linearized problem (a rate over the rows
#: next to a wall grows while the wave arrives there, and the whole cell's decays)
SHORT = 24


def amplitudes(field: np.ndarray, rows=slice(None)) -> np.ndarray:
    """a_k of one snapshot (Nx, Nz) over the z-rows `rows`, k = 0 .. Nx/2 (a_0 = 0: the x-mean removed)."""
    departure = field - field.mean(axis=0)
    return np.sqrt((np.abs(np.fft.rfft(departure, axis=0))[:, rows] ** 2).sum(axis=1))


def growth_rates(snapshots: np.ndarray, times, rows=slice(None), waves=None,
                 floor: float = ROUND_OFF_FLOOR) -> dict[int, float]:
    """{k: growth rate} between the first and last of `snapshots` (times, Nx, Nz) at `times`, for the
    wave numbers `waves` (default: all k >= 1) whose first amplitude is above round-off."""
    a0, a1 = amplitudes(snapshots[0], rows), amplitudes(snapshots[-1], rows)
    waves = range(1, a0.size) if waves is None else [k for k in waves if 0 < k < a0.size]
    measurable = floor * max(a0.max(), a1.max())
    dt = float(times[-1]) - float(times[0])
    return {k: float(np.log(a1[k] / a0[k]) / dt) for k in waves if a0[k] > measurable and a1[k] > 0}


def wall_rows(nz: int, fraction: float = 0.1) -> slice:
    """The z-rows within `fraction` of the height of the moving wall (z = H, the top rows)."""
    return slice(nz - max(1, int(round(fraction * nz))), nz)
