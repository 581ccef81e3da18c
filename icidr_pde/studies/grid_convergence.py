"""Grid-convergence study: error of coarse runs against a fine run, and the observed order.

Run ``icidr-pde study grid-convergence [--scene sine --t 5 --N 51 101 201 401 --ref 1601]``;
the runs are independent: ``--jobs N`` runs them on this machine's process pool, ``--workers N`` /
``--scheduler ADDRESS`` as dask tasks (docs/distributed.md), with the numbers of the serial run.
"""

from __future__ import annotations

import numpy as np

from ..api import run
from ..discretizations import get_discretization
from .case_cache import finished, run_cached

__all__ = ["convergence_study"]


def relative_l2(coarse: dict, ref: dict) -> float:
    """Relative L2 error of (phi, u, w) of two final states (:func:`_run_grid`), the reference
    interpolated to the coarse z."""
    num = den = 0.0
    z = np.asarray(coarse["z"])
    for field in ("phi", "u", "w"):
        ref_values = np.interp(z, ref["z"], ref[field])
        values = np.asarray(coarse[field])
        if field == "phi":  # compare deviations from the mean, not the 0.78 offset
            ref_values, values = ref_values - ref_values.mean(), values - ref_values.mean()
        if field == "u":
            ref_values, values = ref_values - z / coarse["H"], values - z / coarse["H"]
        num += np.sum((values - ref_values) ** 2)
        den += np.sum(ref_values**2)
    return float(np.sqrt(num / den))


def _run_grid(case: dict) -> dict:
    """One grid of the study (a task): api.run of the case, its state at the last time asked
    (z, phi, u, w as lists, the cell height H: JSON values, so that it can be cached)."""
    result = finished(run(**case))
    return {"z": result.z.tolist(), "H": float(result.scene_params["H"]),
            **{field: getattr(result, field)[-1].tolist() for field in ("phi", "u", "w")}}


def convergence_study(rheology="icidr", scene="sine", t=5.0, Ns=(51, 101, 201, 401), N_ref=1601,
                      advection="upwind", rtol=1e-10, atol=1e-12, discretization="fd", *, jobs=1,
                      client=None, progress=True, cache=None):
    """Errors against an N_ref run at time t and the orders log2(e_N / e_2N).

    The N_ref run and the coarse runs are independent: `jobs` worker processes of this
    machine, or tasks of the dask `client` (jobs=1 and no client: one after the other here);
    with `cache` (a folder) each finished grid is kept there and not run again (:func:`run_cached`).
    """
    kwargs = dict(rtol=rtol, atol=atol, discretization=discretization)
    if "advection" in get_discretization(discretization).options:
        kwargs["advection"] = advection
    cases = [dict(rheology=rheology, scene=scene, N=n, t_end=t, times=[t], **kwargs) for n in (N_ref, *Ns)]
    ref, *coarse = run_cached(_run_grid, cases, cache, "grid_convergence", jobs=jobs, progress=progress,
                              desc="grids", client=client, init_here=False)
    errors = {N: relative_l2(result, ref) for N, result in zip(Ns, coarse)}
    Ns = list(Ns)
    orders = [float(np.log(errors[a] / errors[b]) / np.log(b / a)) for a, b in zip(Ns[:-1], Ns[1:])]
    return {"rheology": rheology, "scene": scene, "t": t, "N_ref": N_ref, "advection": advection,
            "discretization": discretization, "errors": {str(k): v for k, v in errors.items()},
            "orders": orders}
