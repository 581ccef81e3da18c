"""Studies of the discrete system: t* against integrator and tolerance, spectral
convergence of the Chebyshev scheme, agreement of discretizations (figs 6, 7)."""

from __future__ import annotations

import numpy as np

from ..cells.shear1d.cheb import interpolate
from ..engines import METHODS
from ..scenes import get_scene
from .failure_time import BDF_ATOL, BDF_RTOL, failure_time
from .parallel import run_cases

__all__ = ["tolerance_study", "spectral_convergence", "compare_discretizations"]


def tolerance_study(
    N: int = 201,
    discretizations=("cheb", "fd"),
    tolerances=((1e-3, 1e-6), (1e-4, 1e-6), (1e-6, 1e-6), (1e-6, 1e-9), (1e-8, 1e-9),
                (1e-8, 1e-12), (1e-10, 1e-12)),
    methods=("BDF", "Radau", "LSODA", "CVODE"),
    method_tolerances=((1e-6, 1e-9), (1e-3, 1e-6)),
    jacobians=None,
    *,
    t_end: float = 0.2,
    jobs: int = 2,
    client=None,
    progress: bool = True,
    **kwargs,
) -> list[dict]:
    """t* of mu(I), IC (3.16) at one N for BDF at several (rtol, atol), and for each method
    at `method_tolerances`. Returns one row per run (failure_time's dict plus the settings).
    The runs are independent: `jobs` worker processes, or tasks of the dask `client`.

    `jacobians` maps (discretization, method) to the Jacobian mode; by default the
    analytic one, except LSODA: dense differences for 'cheb' ('none') and banded
    differences for 'fd' ('banded-fd'), and CVODE on 'fd' ('banded-fd').
    """
    table = {("cheb", "LSODA"): "none", ("fd", "LSODA"): "banded-fd", ("fd", "CVODE"): "banded-fd"}
    table.update(jacobians or {})
    methods = [m for m in methods if m in METHODS]
    cases = []
    for disc in discretizations:
        for rtol, atol in tolerances:
            cases.append(dict(kwargs, discretization=disc, N=N, method="BDF", rtol=rtol, atol=atol))
        for method in methods:
            for rtol, atol in method_tolerances:
                if method == "BDF" and (rtol, atol) in tolerances:
                    continue
                cases.append(dict(kwargs, discretization=disc, N=N, method=method, rtol=rtol,
                                  atol=atol, jacobian=table.get((disc, method), "analytic")))
    for case in cases:
        case.setdefault("rheology", "mui")
        case.setdefault("scene", "shear")
        case.setdefault("t_end", t_end)
    return _run_cases(cases, jobs, progress, client)


def _run_row(case: dict) -> dict:
    res = failure_time(**case)
    defaults = {"method": "BDF", "rtol": BDF_RTOL, "atol": BDF_ATOL}
    return {**{k: case.get(k, defaults.get(k)) for k in ("discretization", "N", "method", "rtol",
                                                          "atol")},
            "jacobian": case.get("jacobian") or "default", "backend": case.get("backend", "numpy"),
            **{k: v for k, v in res.items() if k not in ("N", "jacobian")}}  # the case's jacobian label


def _run_cases(cases: list[dict], jobs: int, progress: bool, client) -> list[dict]:
    """The rows of `cases` in their order: `jobs` worker processes, or tasks of the dask `client`."""
    return list(run_cases(_run_row, cases, jobs, progress, client=client))


def spectral_convergence(
    Ns=tuple(range(9, 62, 4)),
    N_ref: int = 161,
    *,
    rheology: str = "icidr",
    scene: str = "sine",
    t: float = 5.0,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    jobs: int = 2,
    client=None,
    progress: bool = True,
) -> dict:
    """Error of the Chebyshev solution at time `t` against a fine Chebyshev reference.

    The error of N is max over (phi, u, w) and over the N nodes of |f_N - I f_ref|, where
    I interpolates the reference (barycentric, spectrally accurate). Returns
    {"N": [...], "error": [...], "N_ref": N_ref, "rate": r, "fit_N": [...]} where the error
    behaves like C exp(-r N) on the points above the tolerance floor used for the fit.
    The runs go to `jobs` worker processes, or to the dask `client` as tasks.
    """
    Ns = sorted(int(n) for n in Ns)
    base = dict(rheology=rheology, scene=scene, discretization="cheb", t_end=t, rtol=rtol,
                atol=atol, return_state=True)
    cases = [dict(base, N=n) for n in [N_ref] + Ns]
    rows = _run_cases(cases, jobs, progress, client)
    ref = rows[0]
    if ref["t_star"] is not None:
        raise RuntimeError(f"reference run failed at t* = {ref['t_star']}")
    H = float(ref["z"][-1])
    errors = []
    for row in rows[1:]:
        if row["t_star"] is not None:
            errors.append(float("nan"))
            continue
        ref_at_nodes = interpolate(ref["state"], row["z"], H)
        errors.append(float(np.max(np.abs(row["state"] - ref_at_nodes))))
    err = np.array(errors)
    floor = 100 * rtol * np.max(np.abs(ref["state"][1:]))
    fit = np.isfinite(err) & (err > floor)
    rate = float("nan")
    if fit.sum() >= 2:
        rate = float(-np.polyfit(np.array(Ns)[fit], np.log(err[fit]), 1)[0])
    return {"N": Ns, "error": errors, "N_ref": N_ref, "t": t, "rtol": rtol, "atol": atol,
            "rate": rate, "fit_N": [int(n) for n in np.array(Ns)[fit]], "floor": floor,
            "wall_s": [r["wall_s"] for r in rows[1:]]}


def compare_discretizations(
    scene: str = "shear",
    times=None,
    cases=(("cheb", 47), ("cheb", 201), ("fd", 201)),
    *,
    rheology: str = "icidr",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    jobs: int = 2,
    client=None,
    progress: bool = True,
) -> dict:
    """w(z, t) of several discretizations at the times of figs 6, 7, compared on the
    reference nodes of the first Chebyshev case with the most points.

    Returns {"times": [0, ...], "max_w": [...], "diff": {label: [...]}, "failed": {...}}
    where diff is max |w - w_ref| over the nodes of each case (cell centres for 'fd'), the
    reference being interpolated there spectrally (as the figures draw the coarse runs as
    circles at their nodes over the reference line), and max_w the reference amplitude
    max_z |w_ref| (so max_w[0] is that of the initial condition).
    The runs go to `jobs` worker processes, or to the dask `client` as tasks.
    """
    scene_obj = get_scene(scene)
    if times is None:
        times = list(scene_obj.default_times)
    times = sorted({0.0} | {float(t) for t in times})
    runs = [dict(rheology=rheology, scene=scene, discretization=d, N=n, t_end=times[-1],
                 rtol=rtol, atol=atol, times=times) for d, n in cases]
    rows = _run_cases(runs, jobs, progress, client)
    labels = [f"{d}{n}" for d, n in cases]
    by = dict(zip(labels, rows))
    ref_label = max((lab for lab, (d, n) in zip(labels, cases) if d == "cheb"),
                    key=lambda lab: int(lab[4:]))
    H = scene_obj.H
    out = {"times": times, "reference": ref_label, "max_w": [], "diff": {},
           "failed": {lab: by[lab]["t_star"] for lab in labels if by[lab]["t_star"] is not None}}
    ref = by[ref_label]
    n_ref = len(ref["snapshots"])
    for k in range(len(times)):
        out["max_w"].append(float(np.max(np.abs(ref["snapshots"][k][2]))) if k < n_ref
                            else float("nan"))
    for label in labels:
        if label == ref_label:
            continue
        row, diffs = by[label], []
        for k in range(len(times)):
            if k >= len(row["snapshots"]) or k >= n_ref:
                diffs.append(float("nan"))
                continue
            w_ref = interpolate(ref["snapshots"][k][2], row["z"], H)
            diffs.append(float(np.max(np.abs(row["snapshots"][k][2] - w_ref))))
        out["diff"][label] = diffs
    return out
