"""One DEM run: shear to steady state, time-average (appendix C), optional
sine-perturbed transient (section 6, initial condition (5.7)).
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


@dataclass(frozen=True)
class SineIC:
    """Initial velocity profiles (5.7): u = V0 (z/H + a sin 2 pi z/H), w = -b V0 sin 2 pi z/H.

    Args:
        a: amplitude a-hat of the u perturbation (|a| < 1)
        b: amplitude b-hat of w (|b| < 1)
        t_end: duration of the transient (> 0)
        record_every: time between recorded profiles (> 0)
        keep_fluctuations: keep each particle's velocity fluctuation about its bin
            mean (default); False replaces the particle velocities by (5.7) exactly
    """

    a: float = 0.16
    b: float = 0.1
    t_end: float = 20.0
    record_every: float = 0.1
    keep_fluctuations: bool = True

    def __post_init__(self):
        for name in ("a", "b"):
            v = getattr(self, name)
            if not (math.isfinite(v) and abs(v) < 1):
                raise ValueError(f"`{name}` must lie in (-1, 1); got {v}")
        if not (math.isfinite(self.t_end) and self.t_end > 0):
            raise ValueError(f"`t_end` must lie in (0, inf); got {self.t_end}")
        if not (0 < self.record_every <= self.t_end):
            raise ValueError(f"`record_every` must lie in (0, t_end={self.t_end}]; got {self.record_every}")

    def velocities(self, z, H, V0):
        s = np.sin(2 * np.pi * np.asarray(z) / H)
        return V0 * (np.asarray(z) / H + self.a * s), -self.b * V0 * s


def _profiles(snap, bin_height, V0):
    return coarse.profiles(snap.z, snap.u, snap.w, snap.radius, snap.mass, snap.L, snap.H,
                           bin_height, V0)


def run_cell(phi0: float, seed: int, params: DEMParams | None = None,
             protocol: Protocol | None = None, sine: SineIC | None = None) -> dict:
    """Run one cell; returns a dict of numpy arrays/scalars (cache-ready).

    Steady part (appendix C): time-averaged bin profiles of phi, u, w and the
    (C1) stress; cell means p, ||tau||, mu; shear rate from a linear fit of the
    mean u profile; inertial number (2.9).  If ``sine`` is given, the steady
    state is then perturbed by (5.7): each particle gets the (5.7) velocity at
    its centre plus its own fluctuation about its bin mean (so the coarse-grained
    initial fields are (5.7) and the granular temperature is kept) and profiles are recorded for ``sine.t_end``.
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
        if sine is not None:
            out.update(_transient(cell, params, sine))
    out["wall_total"] = time.perf_counter() - wall0
    out["cpu_total"] = time.process_time() - cpu0
    return out


def _transient(cell: ShearCell, params: DEMParams, sine: SineIC) -> dict:
    hb = params.bin_height
    s = cell.snapshot(with_stress=False)
    zz = np.mod(s.z, s.H)
    # fluctuations about the instantaneous bin means (particle centres in bins of 2 d)
    edges = coarse.bin_edges(s.H, hb)
    idx = np.clip(np.searchsorted(edges, zz, side="right") - 1, 0, edges.size - 2)
    m_b = np.bincount(idx, s.mass, minlength=edges.size - 1)
    du = s.u - params.V0 * zz / s.H
    du_b = np.bincount(idx, s.mass * du, minlength=edges.size - 1) / np.maximum(m_b, 1e-300)
    w_b = np.bincount(idx, s.mass * s.w, minlength=edges.size - 1) / np.maximum(m_b, 1e-300)
    u_ic, w_ic = sine.velocities(zz, s.H, params.V0)
    keep = 1.0 if sine.keep_fluctuations else 0.0
    vx = u_ic + keep * (du - du_b[idx])   # (5.7) mean field + the particle's own fluctuation
    vz = w_ic + keep * (s.w - w_b[idx])
    cell.set_velocities(vx, vz)
    t0 = cell.t
    times, phis, us, ws = [], [], [], []
    zc, phi, ub, wb = coarse.profiles(zz, vx, vz, s.radius, s.mass, s.L, s.H, hb, params.V0)
    times.append(0.0), phis.append(phi), us.append(ub), ws.append(wb)
    n_rec = int(round(sine.t_end / sine.record_every))
    for _ in range(n_rec):
        cell.advance(sine.record_every)
        s = cell.snapshot(with_stress=False)
        zc, phi, ub, wb = _profiles(s, hb, params.V0)
        times.append(cell.t - t0), phis.append(phi), us.append(ub), ws.append(wb)
    return {"tr_times": np.array(times), "tr_phi": np.array(phis), "tr_u": np.array(us),
            "tr_w": np.array(ws), "tr_a": sine.a, "tr_b": sine.b}
