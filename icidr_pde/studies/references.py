"""Converged reference solutions for the speed-accuracy study, cached in data/reference/.

Cases (issue "speed-accuracy"):

* ``icidr-shear``: iCIDR, scene shear (3.16), t = 10;
* ``icidr-sine``: iCIDR, scene sine (5.7), t = 20;
* ``mui-shear-tstar-{fd,cheb}``: mu(I),Phi(I), scene shear, failure time t* at N = 201.

The iCIDR references are finite-volume runs at N = 3201 with CVODE at rtol 1e-10,
atol 1e-13. Their convergence is recorded beside them: the difference to N = 1601 (space)
and to rtol 1e-9 (time), both relative to max|w|.
"""

from __future__ import annotations

import json

import numpy as np

from ..api import run
from ..datafiles import data_dir
from .case_cache import finished

__all__ = ["CASES", "case_run", "reference", "reference_tstar", "series_error", "profile_error", "REFERENCE_DIR"]

REFERENCE_DIR = data_dir() / "reference"

CASES = {
    "icidr-shear": dict(rheology="icidr", scene="shear", t_end=10.0, profile_times=[0.5, 1, 2, 5, 10]),
    "icidr-sine": dict(rheology="icidr", scene="sine", t_end=20.0, profile_times=[1, 2, 3, 5, 10, 20]),
}
REF_SETTINGS = dict(N=3201, method="CVODE", rtol=1e-10, atol=1e-13)


def series_times(t_end: float, n: int = 101) -> np.ndarray:
    return np.linspace(0.0, t_end, n)


def case_run(case: str, N: int, rtol: float, atol: float, method: str, discretization="fd",
             jacobian=None):
    """A run of `case` with snapshots at the series times (which contain the profile times)."""
    spec = CASES[case]
    times = series_times(spec["t_end"])
    return finished(run(spec["rheology"], spec["scene"], N, spec["t_end"], list(times),
                        method=method, rtol=rtol, atol=atol, discretization=discretization,
                        jacobian=jacobian, series_times=times))


def series_error(result, ref) -> float:
    """Error of the max|w|(t) series: max over t of |max_i |w(z_i, t)| - max_i |w_ref(z_i, t)||
    relative to max over t of the reference, both maxima over the run's own nodes z_i.

    Taking the reference at the same nodes (linear interpolation from its fine grid)
    removes the sampling error of a maximum over nodes (3e-3 at N = 201 for the sharp
    bump of (3.16) at t = 0), which is not an error of the solution.
    `result` has snapshots at :func:`series_times` (see :func:`case_run`).
    """
    z = result.z
    ref_w = np.array([np.interp(z, ref["z_series"], w) for w in ref["w_series"]])
    n = min(len(result.w), len(ref_w))
    run_max = np.abs(result.w[:n]).max(axis=1)
    ref_max = np.abs(ref_w[:n]).max(axis=1)
    return float(np.max(np.abs(run_max - ref_max)) / np.max(ref_max))


def profile_error(result, ref) -> float:
    """Largest L2 error of the deviations (phi - phi0, u - z/H, w) from steady shear (3.10)
    at the reference's profile times, relative to the largest L2 norm of the reference
    deviations. (Normalising each time by its own norm would blow up as the flow relaxes.)
    """
    H, phi0 = result.scene_params["H"], result.scene_params["phi0"]
    errors, norms = [], []
    for k_ref, t in enumerate(ref["times"]):
        k = int(np.argmin(np.abs(result.times - t)))
        if abs(result.times[k] - t) > 1e-9:
            raise ValueError(f"result has no snapshot at the profile time {t}")
        err2 = ref2 = 0.0
        for name, steady in (("phi", phi0 + 0 * result.z), ("u", result.z / H), ("w", 0 * result.z)):
            r = np.interp(result.z, ref["z"], ref[name][k_ref]) - steady
            err2 += np.sum((getattr(result, name)[k] - steady - r) ** 2)
            ref2 += np.sum(r**2)
        errors.append(np.sqrt(err2))
        norms.append(np.sqrt(ref2))
    return float(max(errors) / max(norms))


def _to_arrays(result, profile_times) -> dict:
    """Full profiles at the profile times; w at every series time on every other node."""
    keep = [int(np.argmin(np.abs(result.times - t))) for t in profile_times]
    return dict(z=result.z, times=result.times[keep], phi=result.phi[keep], u=result.u[keep],
                w=result.w[keep], z_series=result.z[::2], series_t=result.times,
                w_series=result.w[:, ::2])


def reference(case: str, recompute: bool = False) -> dict:
    """Load (or compute and cache) the reference of `case`: arrays plus metadata."""
    if case not in CASES:
        raise ValueError(f"`case` must be one of {sorted(CASES)}; got {case!r}")
    path = REFERENCE_DIR / f"{case}.npz"
    meta_path = REFERENCE_DIR / f"{case}.json"
    if path.exists() and meta_path.exists() and not recompute:
        data = dict(np.load(path))
        data["meta"] = json.loads(meta_path.read_text())
        return data
    REFERENCE_DIR.mkdir(parents=True, exist_ok=True)
    ref = case_run(case, **REF_SETTINGS)
    if ref.blew_up:
        raise RuntimeError(f"reference run of {case} failed: {ref.reason}")
    arrays = _to_arrays(ref, CASES[case]["profile_times"])
    half = case_run(case, REF_SETTINGS["N"] // 2, REF_SETTINGS["rtol"], REF_SETTINGS["atol"], REF_SETTINGS["method"])
    looser = case_run(case, REF_SETTINGS["N"], 10 * REF_SETTINGS["rtol"], 10 * REF_SETTINGS["atol"], REF_SETTINGS["method"])
    meta = dict(case=case, **CASES[case], **REF_SETTINGS, scene_params=ref.scene_params,
                material=ref.material, wall_s=ref.wall_s, mass_drift=ref.mass_drift,
                space_check=dict(N=half.N, series_error=series_error(half, arrays),
                                 profile_error=profile_error(half, arrays)),
                time_check=dict(rtol=looser.rtol, series_error=series_error(looser, arrays),
                                profile_error=profile_error(looser, arrays)))
    np.savez_compressed(path, **{k: np.asarray(v, dtype=np.float32 if k == "w_series" else np.float64)
                                 for k, v in arrays.items()})
    meta_path.write_text(json.dumps(meta, indent=1))
    arrays["meta"] = meta
    return arrays


TSTAR_SETTINGS = dict(N=201, method="BDF", rtol=1e-10, atol=1e-13)


def reference_tstar(discretization: str, recompute: bool = False) -> dict:
    """Case (iii): failure time t* of mu(I), scene shear, N = 201, at tight tolerance.

    t* belongs to the discrete system (grid, scheme, integrator, tolerance), so the
    reference records the values at rtol 1e-10 and 1e-9 with BDF and at 1e-10 with Radau;
    their spread is the uncertainty of the reference.
    """
    path = REFERENCE_DIR / f"mui-shear-tstar-{discretization}.json"
    if path.exists() and not recompute:
        return json.loads(path.read_text())
    values = {}
    for method, rtol in (("BDF", 1e-10), ("BDF", 1e-9), ("Radau", 1e-10)):
        res = finished(run("mui", "shear", TSTAR_SETTINGS["N"], 1.0, [0.0], discretization=discretization,
                           method=method, rtol=rtol, atol=rtol * 1e-3))
        values[f"{method} rtol={rtol:g}"] = res.t_star
    data = dict(discretization=discretization, **TSTAR_SETTINGS,
                t_star=values[f"BDF rtol={TSTAR_SETTINGS['rtol']:g}"], variants=values,
                spread=max(values.values()) - min(values.values()))
    REFERENCE_DIR.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1))
    return data
