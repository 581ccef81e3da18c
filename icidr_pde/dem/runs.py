"""One steady DEM run: shear to steady state and time-average (appendix C).

The (5.7) transient of section 6 is :mod:`icidr_pde.dem.ensemble`.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from . import coarse
from .driver import ShearCell
from .params import DEMParams


@dataclass(frozen=True)
class Protocol:
    """Times (in d/V0 units) of one run.

    Args:
        t_shear: shearing before averaging starts (>= 0)
        t_avg: averaging window (> 0)
        sample_every: time between averaged snapshots (> 0, <= t_avg)
    """

    t_shear: float = 30.0
    t_avg: float = 100.0
    sample_every: float = 0.5

    def __post_init__(self):
        if not (math.isfinite(self.t_shear) and self.t_shear >= 0):
            raise ValueError(f"`t_shear` must lie in [0, inf); got {self.t_shear}")
        if not (math.isfinite(self.t_avg) and self.t_avg > 0):
            raise ValueError(f"`t_avg` must lie in (0, inf); got {self.t_avg}")
        if not (0 < self.sample_every <= self.t_avg):
            raise ValueError(f"`sample_every` must lie in (0, t_avg={self.t_avg}]; got {self.sample_every}")


def _profiles(snap, bin_height, V0):
    return coarse.profiles(snap.z, snap.u, snap.w, snap.radius, snap.mass, snap.L, snap.H,
                           bin_height, V0)


def run_cell(phi0: float, seed: int, params: DEMParams | None = None,
             protocol: Protocol | None = None) -> dict:
    """Run one cell; returns a dict of numpy arrays/scalars (cache-ready).

    Steady part (appendix C): time-averaged bin profiles of phi, u, w and the
    (C1) stress; cell means p, ||tau||, mu; shear rate from a linear fit of the
    mean u profile; inertial number (2.9).
    """
    params = params or DEMParams()
    protocol = protocol or Protocol()
    hb = params.bin_height
    wall0 = time.perf_counter()
    cpu0 = time.process_time()
    out: dict = {"phi0": phi0, "seed": seed, "params": str(asdict(params)),
                 "protocol": str(asdict(protocol)), "dt": params.dt}
    with ShearCell(phi0, seed, params) as cell:
        # shear towards steady state, keeping a coarse time series of p and mu
        ts_t, ts_p, ts_mu = [], [], []
        n_pre = max(1, int(round(protocol.t_shear / 5.0))) if protocol.t_shear > 0 else 0
        for _ in range(n_pre):
            cell.advance(protocol.t_shear / n_pre)
            s = cell.snapshot()
            P = coarse.stress_profile(s.z, s.u, s.w, s.mass, s.virial, s.L, s.H, params.V0, hb).mean(0)
            p, _, mu = coarse.invariants(P)
            ts_t.append(cell.t), ts_p.append(p), ts_mu.append(mu)
        n_avg = max(1, int(round(protocol.t_avg / protocol.sample_every)))
        acc = {k: [] for k in ("phi", "u", "w", "P")}
        for _ in range(n_avg):
            cell.advance(protocol.sample_every)
            s = cell.snapshot()
            zc, phi, ub, wb = _profiles(s, hb, params.V0)
            P = coarse.stress_profile(s.z, s.u, s.w, s.mass, s.virial, s.L, s.H, params.V0, hb)
            acc["phi"].append(phi), acc["u"].append(ub), acc["w"].append(wb), acc["P"].append(P)
            p, _, mu = coarse.invariants(P.mean(0))
            ts_t.append(cell.t), ts_p.append(p), ts_mu.append(mu)
        prof = {k: np.mean(v, axis=0) for k, v in acc.items()}
        slope, _ = np.polyfit(zc, prof["u"], 1)
        Pm = prof["P"].mean(axis=0)
        p, tau, mu = coarse.invariants(Pm)
        # Lees-Edwards makes the cell-mean shear rate exactly V0/H; the fitted
        # slope of the mean u profile is kept as a check (shear_rate)
        out.update(
            z=zc, phi_profile=prof["phi"], u_profile=prof["u"], w_profile=prof["w"],
            P_profile=prof["P"], P_mean=Pm, p=p, tau=tau, mu=mu, shear_rate=slope,
            I=coarse.inertial_number(params.shear_rate, p, rho=params.rho),
            I_fitted_slope=coarse.inertial_number(slope, p, rho=params.rho), phi_mean=prof["phi"].mean(),
            ts_t=np.array(ts_t), ts_p=np.array(ts_p), ts_mu=np.array(ts_mu),
            L=cell.L, H=params.H, n_particles=params.n_particles,
        )
        out["wall_steady"] = time.perf_counter() - wall0
    out["wall_total"] = time.perf_counter() - wall0
    out["cpu_total"] = time.process_time() - cpu0
    return out
