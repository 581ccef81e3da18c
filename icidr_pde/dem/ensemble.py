"""The (5.7) transient of section 6 as a protocol with every choice explicit.

One *base state* per (seed, cell, preparation, shearing time): an appendix-C
cell sheared to steady state, stored as a LAMMPS restart file (positions,
velocities, spins, contact history).  Several *perturbations* branch from the
same base state, so two variants of the imposition are compared on identical
microscopic states (paired differences have much less noise than two
independent ensembles).

A perturbation replaces the mean velocity field by (5.7) and decides what to
do with each particle's fluctuation about its bin mean (``fluctuations``):

* ``keep``  -- (5.7) at the particle centre + the particle's own fluctuation
  (the granular temperature of uniform shear is kept);
* ``drop``  -- (5.7) exactly, zero granular temperature;
* ``local`` -- the fluctuation scaled by 2||S||/(V0/H) of the (5.7) field at the
  particle: the temperature of steady flow at the local strain rate (in the
  inertial regime velocity fluctuations scale as d ||S|| at fixed phi); the
  scale varies inside a bin, so bin means move by a small fraction of the
  fluctuation (~1e-3 V0 per member, zero on average).

Profiles are recorded as additive sums on fine bins (:func:`coarse.layer_moments`
plus second velocity moments and the contact virial per bin), so bin size,
velocity definition, frame of u, granular temperature and stress are all
post-processing.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..outputs import replacing
from ..studies.parallel import run_cases

from . import cache, coarse
from .driver import PREPARATIONS, ShearCell
from .params import DEMParams

FLUCTUATIONS = ("keep", "drop", "local")


@dataclass(frozen=True)
class BaseState:
    """How the steady state before the perturbation is made.

    Args:
        phi0: mean packing fraction (0.78 in section 6)
        params: cell and contact law (:class:`DEMParams`)
        preparation: 'minimize' or 'rescale' (see :class:`ShearCell`)
        t_shear: Lees-Edwards shearing from the linear profile before the perturbation (> 0)
    """

    phi0: float = 0.78
    params: DEMParams = field(default_factory=DEMParams)
    preparation: str = "minimize"
    t_shear: float = 30.0

    def __post_init__(self):
        if self.preparation not in PREPARATIONS:
            raise ValueError(f"`preparation` must be one of {PREPARATIONS}; got {self.preparation!r}")
        if not (math.isfinite(self.t_shear) and self.t_shear > 0):
            raise ValueError(f"`t_shear` must lie in (0, inf); got {self.t_shear}")

    def key(self, seed: int) -> str:
        h = hashlib.sha1(repr((asdict(self.params), self.preparation, self.t_shear)).encode()).hexdigest()[:8]
        return f"base_phi{self.phi0:.4f}_N{self.params.n_particles}_H{self.params.H:g}_s{seed}_{h}"


@dataclass(frozen=True)
class Perturbation:
    """(5.7) imposed on a base state and recorded.

    Args:
        a, b: amplitudes of (5.7) (|a|, |b| < 1)
        fluctuations: 'keep', 'drop' or 'local' (module docstring)
        t_end: duration (> 0)
        record_every: time between records (> 0)
        dt_fraction: time step of the transient / shortest contact time (None: the base state's)
        record_bin: height of the recording bins (must divide H; 1 d allows 1, 2, 3, 5, 6 d later)
    """

    a: float = 0.16
    b: float = 0.1
    fluctuations: str = "keep"
    t_end: float = 20.0
    record_every: float = 0.1
    dt_fraction: float | None = None
    record_bin: float = 1.0

    def __post_init__(self):
        for name in ("a", "b"):
            v = getattr(self, name)
            if not (math.isfinite(v) and abs(v) < 1):
                raise ValueError(f"`{name}` must lie in (-1, 1); got {v}")
        if self.fluctuations not in FLUCTUATIONS:
            raise ValueError(f"`fluctuations` must be one of {FLUCTUATIONS}; got {self.fluctuations!r}")
        if not (math.isfinite(self.t_end) and self.t_end > 0):
            raise ValueError(f"`t_end` must lie in (0, inf); got {self.t_end}")
        if not (0 < self.record_every <= self.t_end):
            raise ValueError(f"`record_every` must lie in (0, t_end={self.t_end}]; got {self.record_every}")
        if self.dt_fraction is not None and not (0 < self.dt_fraction <= 0.2):
            raise ValueError(f"`dt_fraction` must lie in (0, 0.2] or be None; got {self.dt_fraction}")
        if not self.record_bin > 0:
            raise ValueError(f"`record_bin` must be > 0; got {self.record_bin}")

    def key(self) -> str:
        return hashlib.sha1(repr(asdict(self)).encode()).hexdigest()[:8]

    def velocities(self, z, H, V0):
        """(5.7) at heights z: u = V0 (z/H + a sin 2 pi z/H), w = -b V0 sin 2 pi z/H."""
        s = np.sin(2 * np.pi * np.asarray(z) / H)
        return V0 * (np.asarray(z) / H + self.a * s), -self.b * V0 * s

    def strain_rate_ratio(self, z, H):
        """2||S|| of (5.7) over its steady value V0/H.

        In the 1-D cell the deviatoric strain rate (2.5) has S_xz = u_z/2 and
        S_zz = -S_xx = w_z/2, so 2||S|| = sqrt(u_z^2 + w_z^2) with the norm of (2.6).
        """
        c = np.cos(2 * np.pi * np.asarray(z) / H)
        uz = 1 + 2 * np.pi * self.a * c
        wz = -2 * np.pi * self.b * c
        return np.hypot(uz, wz)


def _bin_index(z, H, hb):
    edges = coarse.bin_edges(H, hb)
    return np.clip(np.searchsorted(edges, np.mod(z, H), side="right") - 1, 0, edges.size - 2), edges.size - 1


def record(snap, hb, V0) -> dict:
    """Additive sums per bin of height ``hb`` at one instant (fine-bin record)."""
    mom = coarse.layer_moments(snap.z, snap.u, snap.w, snap.radius, snap.mass, snap.L, snap.H, hb, V0)
    idx, nb = _bin_index(snap.z, snap.H, hb)
    m = snap.mass
    zz = np.mod(snap.z, snap.H)
    # Lees-Edwards-continuous velocity: u - V0 z/H is the same for a disk and its images
    du = snap.u - V0 * zz / snap.H
    mom["muu_centre"] = np.bincount(idx, m * du * du, minlength=nb)
    mom["mdu_centre"] = np.bincount(idx, m * du, minlength=nb)
    mom["mww_centre"] = np.bincount(idx, m * snap.w * snap.w, minlength=nb)
    mom["muw_centre"] = np.bincount(idx, m * du * snap.w, minlength=nb)
    if np.all(np.isfinite(snap.virial)):
        for j, c in enumerate(("xx", "zz", "xz")):
            mom[f"vir_{c}"] = np.bincount(idx, snap.virial[:, j], minlength=nb)
    return mom


def impose(snap, pert: Perturbation, params: DEMParams, hb: float = 2.0):
    """Particle velocities of the perturbed state (module docstring).  Fluctuations
    are taken about the bin means (centre binning, bins of ``hb``) of u - V0 z/H and w."""
    zz = np.mod(snap.z, snap.H)
    idx, nb = _bin_index(zz, snap.H, hb)
    m = snap.mass
    mb = np.maximum(np.bincount(idx, m, minlength=nb), 1e-300)
    du = snap.u - params.V0 * zz / snap.H
    du_f = du - (np.bincount(idx, m * du, minlength=nb) / mb)[idx]
    w_f = snap.w - (np.bincount(idx, m * snap.w, minlength=nb) / mb)[idx]
    scale = {"keep": 1.0, "drop": 0.0, "local": pert.strain_rate_ratio(zz, snap.H)}[pert.fluctuations]
    u_ic, w_ic = pert.velocities(zz, snap.H, params.V0)
    return u_ic + scale * du_f, w_ic + scale * w_f


def _stack(records):
    return {k: np.array([r[k] for r in records]) for k in records[0]}


def run_perturbation(cell: ShearCell, pert: Perturbation, params: DEMParams) -> dict:
    """Impose ``pert`` on the cell's current state and record it."""
    hb = pert.record_bin
    coarse.bin_edges(params.H, hb)  # validates that hb divides H
    if pert.dt_fraction is not None:
        cell.set_timestep(pert.dt_fraction / params.dt_fraction * params.dt)
    s = cell.snapshot(with_stress=True)
    vx, vz = impose(s, pert, params)
    cell.set_velocities(vx, vz)
    s.u, s.w = vx, vz
    offset = coarse.streaming_offset(s.z, vx, s.mass, params.V0, s.H)
    t0 = cell.t
    times, recs = [0.0], [record(s, hb, params.V0)]
    for _ in range(int(round(pert.t_end / pert.record_every))):
        cell.advance(pert.record_every)
        recs.append(record(cell.snapshot(with_stress=True), hb, params.V0))
        times.append(cell.t - t0)
    out = {f"m_{k}": v.astype(np.float32) for k, v in _stack(recs).items()}
    out.update(times=np.array(times), L=s.L, H=s.H, V0=params.V0, record_bin=hb,
               offset0=offset, a=pert.a, b=pert.b)
    return out


def _cpu():
    return time.process_time()


def run_ensemble_member(base: BaseState, seed: int, perts, cache_dir, keep_restart=True):
    """Results of each perturbation in ``perts`` branching from one base state.

    Each result is cached as ``<base key>_<perturbation key>.npz``; the base
    state itself as a restart file ``<base key>.restart``.  Only what is
    missing is run.  Each result carries ``cpu_s`` (CPU seconds of its own
    transient) and ``cpu_base_s`` (of the base state, 0 when reused).
    """
    cache_dir = Path(cache_dir)
    cache_dir.mkdir(parents=True, exist_ok=True)
    bkey = base.key(seed)
    results, missing = {}, []
    for p in perts:
        r = cache.load(cache_dir, f"{bkey}_{p.key()}")
        if r is None:
            missing.append(p)
        else:
            results[p] = r
    if missing:
        restart = cache_dir / f"{bkey}.restart"
        cpu_base = 0.0
        if not restart.exists():
            c0 = _cpu()
            with ShearCell(base.phi0, seed, base.params, preparation=base.preparation) as cell:
                cell.advance(base.t_shear)
                with replacing(restart) as tmp:
                    cell.write_restart(tmp)
            cpu_base = _cpu() - c0
        for p in missing:
            c0 = _cpu()
            with ShearCell(base.phi0, seed, base.params, restart=restart) as cell:
                r = run_perturbation(cell, p, base.params)
            r.update(cpu_s=_cpu() - c0, cpu_base_s=cpu_base, seed=seed, phi0=base.phi0,
                     base=bkey, perturbation=repr(p))
            cpu_base = 0.0
            cache.save(cache_dir, f"{bkey}_{p.key()}", r)
            results[p] = cache.load(cache_dir, f"{bkey}_{p.key()}")
        if not keep_restart:
            restart.unlink(missing_ok=True)
    return [results[p] for p in perts]


def member_task(case: dict) -> list:
    """One member (a task of :func:`run_ensemble` and of the audit): :func:`run_ensemble_member` of
    the case's base state, seed, perturbations and cache folder."""
    return run_ensemble_member(case["base"], case["seed"], case["perts"], case["cache_dir"])


def run_ensemble(base: BaseState, seeds, perts, cache_dir, *, jobs: int = 1, client=None, progress: bool = False):
    """:func:`run_ensemble_member` for every seed: [results of `perts` per seed], in the order of `seeds`.

    The members are independent LAMMPS runs: `jobs` worker processes of this machine, or tasks
    of the dask `client` (neither: one after the other here). Each writes its results to
    `cache_dir` as it finishes (so the ensemble resumes from the cache as before); on a cluster
    `cache_dir` must be a folder every worker sees.
    """
    cases = [dict(base=base, seed=int(seed), perts=list(perts), cache_dir=str(cache_dir)) for seed in seeds]
    return list(run_cases(member_task, cases, jobs, progress, desc="DEM members", client=client,
                          init_here=False))


def seeds(n, base_seed=1, phi0=0.78):
    """Seeds of the ensemble members (same scheme as the steady study)."""
    return [cache.run_seed(base_seed, r, phi0) for r in range(n)]


# ------------------------------------------------------------------ analysis
def fields(result: dict, bin_height=2.0, definition="slab_mass", frame="offset"):
    """(times, z centres, phi, u, w) of one run on bins of ``bin_height``.

    ``frame`` fixes the Galilean frame of u (the continuum has u(0) = 0, u(H) = V0):
    'offset' removes the conserved streaming offset c (mass mean of u - V0 z/H,
    measured at t = 0; (5.7) has c = 0); 'layers' removes, at every time, the
    velocity of the z = 0 layer estimated from the bottom and top bins,
    (u_bottom + u_top - V0)/2 -- the paper's "relative velocity between the
    bottom and top layers"; 'lab' keeps LAMMPS' frame (bottom boundary at rest).
    """
    hb = float(result["record_bin"])
    merge = int(round(bin_height / hb))
    if merge < 1 or abs(merge * hb - bin_height) > 1e-9:
        raise ValueError(f"`bin_height` must be a multiple of the recorded {hb}; got {bin_height}")
    mom = {k[2:]: v for k, v in result.items() if k.startswith("m_")}
    phi, u, w = coarse.fields_from_moments(mom, float(result["L"]), hb, definition, merge)
    V0 = float(result["V0"])
    nb = phi.shape[-1]
    z = (np.arange(nb) + 0.5) * bin_height
    if frame == "offset":
        u = u - float(result["offset0"])
    elif frame == "layers":
        u = u - 0.5 * (u[:, :1] + u[:, -1:] - V0)
    elif frame != "lab":
        raise ValueError(f"`frame` must be 'offset', 'layers' or 'lab'; got {frame!r}")
    return np.asarray(result["times"]), z, phi, u, w


def temperature(result: dict, bin_height=2.0):
    """Granular temperature T = <|v - <v>|^2>/2 per bin (centre binning) over time."""
    hb = float(result["record_bin"])
    merge = int(round(bin_height / hb))
    g = {k: result[f"m_{k}"].astype(float) for k in ("m_centre", "mdu_centre", "muu_centre",
                                                      "mww_centre", "pw_centre")}
    nb = g["m_centre"].shape[-1]
    g = {k: v.reshape(*v.shape[:-1], nb // merge, merge).sum(-1) for k, v in g.items()}
    m = g["m_centre"]
    with np.errstate(invalid="ignore", divide="ignore"):
        var_u = g["muu_centre"] / m - (g["mdu_centre"] / m) ** 2
        var_w = g["mww_centre"] / m - (g["pw_centre"] / m) ** 2
    return 0.5 * (var_u + var_w)
