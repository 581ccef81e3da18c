"""Studies of the 2-D shear cell (scene ``bump2d``), their tables, field images and movie.

``icidr-pde study sim2d convergence`` -- iCIDR on bump2d at 16^2 .. 128^2: max_w,
max_phi_dev, l2_velocity at t = 0.5, 1, 2, 5, 10 and the observed orders
(data/sim2d/convergence.json);
``icidr-pde study sim2d tstar`` -- mu(I),Phi(I) on bump2d at 16^2 .. 128^2: the
failure time t* of every 2-D grid beside the 1-D finite-volume run of the same perturbation
made x-independent (w = eps ((z - H/2)/ell) exp(-(z - H/2)^2/ell^2)) at N = Nz
(data/sim2d/tstar.json);
``icidr-pde study sim2d growth`` -- mode2d waves at several angles, the measured
growth rate against the symbol of :mod:`stability.directional` (data/sim2d/mode_growth.json);
``icidr-pde study sim2d tables`` -- the tables of docs/sim2d.md from those files.

convergence and tstar take the integrator settings (``--rtol``, ``--atol``, ``--jacobian``; default
:data:`SETTINGS` and :data:`SOLVER_2D`, which computed the committed files); the grids beyond 128^2
run on the stable 2-D default (data/sim2d/convergence_large.json, tstar_large.json: docs/sim2d.md,
"Grids beyond 128²"). Each JSON's "command" reruns it (:func:`study_command`); grids run apart
become one study's JSON with :func:`combine_studies`.

The field images and the movie of docs/sim2d.md are drawn by :mod:`icidr_pde.figures.sim2d_fields`.

Every run goes through :func:`icidr_pde.api.run` (one case builder, one run path). The runs of
a study are independent: ``--jobs N`` runs them on this machine's process pool, ``--workers N`` /
``--scheduler ADDRESS`` as dask tasks (docs/distributed.md), with the numbers of the serial run
(default: one after the other in this process).
"""

from __future__ import annotations

import math
import pathlib

import numpy as np

from ..outputs import write_json
from .case_cache import finished, run_cached

__all__ = ["convergence_study", "tstar_study", "growth_study", "convergence_table", "tstar_table", "growth_table",
           "observed_orders", "mode_growth", "predicted_growth", "study_command", "combine_studies", "SETTINGS", "SOLVER_2D",
           "SIZES", "TSTAR_SIZES"]

TIMES = ("0.5", "1", "2", "5", "10")
SIZES = (16, 32, 64, 128)
TSTAR_SIZES = (16, 24, 32, 48, 64, 96, 128)
QUANTITIES = ("max_w", "max_phi_dev", "l2_velocity")
DATA = pathlib.Path("data") / "sim2d"
#: integrator settings of the studies (CVODE, matrix-free GMRES; tolerances well below the grid errors)
SETTINGS = dict(method="CVODE", rtol=1e-7, atol=1e-10)
#: the linear solver of the studies' 2-D runs: GMRES without a preconditioner, which computed the
#: committed data/sim2d (the py-pde default beyond 64^2 is now the x-Fourier preconditioner, whose
#: measures and t* agree with it to the time-integration error: docs/scaling.md)
SOLVER_2D = dict(jacobian="krylov")


def _solver_2d(settings: dict) -> dict:
    """The linear solver of a 2-D run of the studies: :data:`SOLVER_2D`, or the PETSc engine's own
    (its Newton systems are sparse matrices: ``engine="petsc"`` in the settings)."""
    return {} if settings.get("engine") == "petsc" else SOLVER_2D


def study_command(part: str, settings: dict, sizes, default_sizes, path, default_path) -> str:
    """The ``icidr-pde study sim2d PART`` line that reruns a study: ``--sizes`` where not the
    study's, the settings that differ from :data:`SETTINGS` and :data:`SOLVER_2D` as their options
    (``--advection``, ``--engine``, ``--rtol``, ``--atol``, ``--jacobian``), ``--json`` where `path`
    is not where the command writes by default (`default_path`)."""
    words = ["icidr-pde study sim2d", part]
    if tuple(sizes) != tuple(default_sizes):
        words += ["--sizes", *map(str, sizes)]
    words += [f"--{key} {settings[key]}" for key in ("advection", "engine") if key in settings]
    # repr: the tolerance as the run had it, to the last digit
    words += [f"--{key} {settings[key]!r}" for key in ("rtol", "atol") if settings[key] != SETTINGS[key]]
    if settings.get("jacobian", SOLVER_2D["jacobian"]) != SOLVER_2D["jacobian"]:
        words.append(f"--jacobian {settings['jacobian']}")
    if pathlib.Path(path) != pathlib.Path(default_path):
        words.append(f"--json {path}")
    return " ".join(words)


def observed_orders(values: list[float]) -> list[float | None]:
    """log2 of successive difference ratios |q_N - q_2N| / |q_2N - q_4N| (grids doubling)."""
    out = []
    for a, b, c in zip(values, values[1:], values[2:]):
        d1, d2 = abs(a - b), abs(b - c)
        out.append(math.log2(d1 / d2) if d1 > 0 and d2 > 0 else None)
    return out


def _convergence_run(case: dict) -> tuple[dict, str]:
    """One grid of :func:`convergence_study` (a task): the run's JSON fields of the study and its summary."""
    from ..api import run

    n, times = case["n"], case["times"]
    result = finished(run("icidr", "bump2d", (n, n), float(times[-1]), list(times),
                          **{**_solver_2d(case["settings"]), **case["settings"]}))
    fields = {k: v for k, v in result.to_dict().items()
              if k in ("Nx", "Nz", "L", "blew_up", "reason", "mass_drift", "wall_s", "n_rhs", *QUANTITIES)}
    return fields, str(result)


def convergence_study(sizes=SIZES, times=TIMES, path=DATA / "convergence.json", *, jobs=1, client=None,
                      progress=False, cache=None, **settings) -> dict:
    """iCIDR on bump2d at Nx = Nz = N for each N in `sizes`; the JSON of each run plus orders.

    The grids run in `jobs` worker processes or as tasks of the dask `client` (neither: here);
    with `cache` (a folder) each finished grid is kept there and not run again (:func:`run_cached`)."""
    settings = {**SETTINGS, **settings}
    cases = [dict(n=n, times=list(times), settings=settings) for n in sizes]
    runs = {}
    for n, (fields, summary) in zip(sizes, run_cached(_convergence_run, cases, cache, "sim2d.convergence", jobs=jobs,
                                                      progress=progress, desc="grids", client=client,
                                                      init_here=False)):
        runs[str(n)] = fields
        print(f"iCIDR bump2d {n}x{n}: {summary}", flush=True)
    payload = _convergence_payload(sizes, times, settings, runs, path)
    write_json(payload, path)
    return payload


def _convergence_payload(sizes, times, settings: dict, runs: dict, path) -> dict:
    """The convergence study's JSON: its runs by grid, the observed orders over `sizes`, the command."""
    orders = {q: {t: observed_orders([runs[str(n)][q][t] for n in sizes]) for t in times} for q in QUANTITIES}
    default_path = DATA / ("convergence_upwind.json" if settings.get("advection") == "upwind" else "convergence.json")
    return {"scene": "bump2d", "rheology": "icidr", "sizes": list(sizes), "times": list(times),
            "settings": settings, "runs": {str(n): runs[str(n)] for n in sizes}, "observed_orders": orders,
            "command": study_command("convergence", settings, sizes, SIZES, path, default_path)}


def _tstar_run(case: dict) -> tuple[float | None, str | None, float | None, str]:
    """One run of :func:`tstar_study` (a task): mu(I) on bump2d (``case["dim"] == 2``, n^2 cells)
    or on its x-independent 1-D fd form (n cells): t*, the reason, max|w| at the end of a 1-D run
    that did not fail, the summary."""
    from ..api import run
    from ..cells.plane2d.scenes import Bump2DScene

    n, t_end, settings = case["n"], case["t_end"], case["settings"]
    times = ["0", f"{t_end:g}"]
    if case["dim"] == 2:
        r = finished(run("mui", "bump2d", (n, n), t_end, times, series_times=[], **{**_solver_2d(settings), **settings}))
        return r.t_star, r.reason, None, str(r)
    # the 1-D runs: the study's CVODE with the 1-D default linear solver (engine and jacobian name the 2-D runs')
    one_d = {k: v for k, v in settings.items() if k not in ("engine", "jacobian")}
    r = finished(run("mui", Bump2DScene().x_independent(), n, t_end, times, discretization="fd", series_times=[],
                     **one_d))
    return r.t_star, r.reason, None if r.blew_up else float(np.max(np.abs(r.final[2]))), str(r)


def tstar_study(sizes=TSTAR_SIZES, t_end=10.0, path=DATA / "tstar.json", *, jobs=1, client=None,
                progress=False, cache=None, **settings) -> dict:
    """mu(I),Phi(I) on bump2d (2-D) and its x-independent perturbation (1-D fd) at N = Nz.

    The runs (two per N) go to `jobs` worker processes or to the dask `client` (neither: here);
    with `cache` (a folder) each finished run is kept there and not run again (:func:`run_cached`)."""
    settings = {**SETTINGS, **settings}
    cases = [dict(dim=dim, n=n, t_end=t_end, settings=settings) for n in sizes for dim in (2, 1)]
    done = iter(run_cached(_tstar_run, cases, cache, "sim2d.tstar", jobs=jobs, progress=progress, desc="runs",
                           client=client, init_here=False))
    rows = []
    for n in sizes:
        (t2, reason2, _, s2), (t1, reason1, max_w1, s1) = next(done), next(done)
        rows.append({"N": n, "t_star_2d": t2, "reason_2d": reason2, "t_star_1d": t1,
                     "reason_1d": reason1, "max_w_1d_end": max_w1})
        print(f"mu(I) bump2d N = {n}: 2-D {s2}; 1-D {s1}", flush=True)
    payload = _tstar_payload(sizes, t_end, settings, rows, path)
    write_json(payload, path)
    return payload


def _tstar_payload(sizes, t_end: float, settings: dict, rows: list[dict], path) -> dict:
    """The t* study's JSON: its rows (in the order of `sizes`) and the command."""
    return {"scene": "bump2d", "rheology": "mui", "t_end": t_end, "settings": settings, "rows": rows,
            "command": study_command("tstar", settings, sizes, TSTAR_SIZES, path, DATA / "tstar.json")}


def combine_studies(parts, path) -> dict:
    """One study's JSON from the JSONs of its grids run apart (`parts`: payloads or their files, all
    convergence or all tstar, with the same settings and times), as the study would have written
    them run together: grids in increasing N, the observed orders over all of them, the command
    of all the sizes writing `path`; written to `path`."""
    import json

    parts = [json.loads(pathlib.Path(p).read_text()) if not isinstance(p, dict) else p for p in parts]
    if not parts:
        raise ValueError("`parts` must name at least one study JSON; got none")
    first = parts[0]
    same = ("rheology", "settings", "times") if "runs" in first else ("rheology", "settings", "t_end")
    for other in parts[1:]:
        for key in same:
            if other.get(key) != first.get(key):
                raise ValueError(f"`parts` must be grids of one study: {key} {first.get(key)!r} against "
                                 f"{other.get(key)!r}")
    if "runs" in first:
        runs = {n: run for part in parts for n, run in part["runs"].items()}
        sizes = sorted(int(n) for n in runs)
        payload = _convergence_payload(sizes, first["times"], first["settings"], runs, path)
    else:
        rows = {row["N"]: row for part in parts for row in part["rows"]}
        sizes = sorted(rows)
        payload = _tstar_payload(sizes, first["t_end"], first["settings"], [rows[n] for n in sizes], path)
    write_json(payload, path)
    return payload


def _fmt(x, spec=".4e"):
    return "–" if x is None else format(x, spec)


def convergence_table(payload: dict) -> str:
    """Markdown: one row per grid, max_w / max_phi_dev / l2_velocity at each time, then orders."""
    times, sizes = payload["times"], payload["sizes"]
    lines = []
    for q in QUANTITIES:
        lines.append(f"**{q}**\n")
        lines.append("| grid | " + " | ".join(f"t = {t}" for t in times) + " |")
        lines.append("| --- |" + " --- |" * len(times))
        for n in sizes:
            run = payload["runs"][str(n)]
            lines.append(f"| {n}² | " + " | ".join(_fmt(run[q].get(t)) for t in times) + " |")
        for k, n in enumerate(sizes[2:]):
            lines.append(f"| order ({sizes[k]}², {sizes[k + 1]}², {n}²) | "
                         + " | ".join(_fmt(payload["observed_orders"][q][t][k], ".2f") for t in times) + " |")
        lines.append("")
    return "\n".join(lines)


def tstar_table(payload: dict) -> str:
    """Markdown: t* of mu(I) on bump2d against N, 2-D beside the x-independent 1-D run."""
    lines = ["| N (2-D: N², 1-D: N cells) | 2-D bump2d t* | 1-D, x-independent bump |", "| --- | --- | --- |"]
    for row in payload["rows"]:
        one_d = (f"fails, t* = {row['t_star_1d']:.4g}" if row["t_star_1d"] is not None
                 else f"decays (max\\|w\\|(10) = {row['max_w_1d_end']:.2e})")
        two_d = f"{row['t_star_2d']:.4g}" if row["t_star_2d"] is not None else "no failure"
        lines.append(f"| {row['N']} | {two_d} | {one_d} |")
    return "\n".join(lines)


# --- growth of oblique modes against the symbol ---------------------------------------------


def predicted_growth(rheology, scene, material=None) -> dict:
    """The symbol's growth rates for the plane-wave components of a mode2d scene.

    sin(k n.x) sin(pi z/H) is the sum of the waves (k_x, k_z +- pi/H); returns the largest
    max Re eig A(xi, n) over them (stability.directional.symbol_matrix at steady shear,
    velocity gradient u_z = 1/H) and xi^2 Lambda_max(theta) of the nominal wave.
    """
    from stability import directional

    L_ = (0.0, 1.0 / scene.H, 0.0, 0.0)
    a, B = directional.principal_part(rheology, scene.phi0, L_, material)
    kx, kz = scene.wave_vector()
    rates = []
    for kz_ in (kz + np.pi / scene.H, kz - np.pi / scene.H):
        xi, angle = math.hypot(kx, kz_), math.degrees(math.atan2(kz_, kx)) % 180.0
        rates.append(float(np.max(np.linalg.eigvals(directional.symbol_matrix(a, B, scene.phi0, xi, angle)).real)))
    lam = directional.lambda_max_function(a, B)
    xi, angle = math.hypot(kx, kz), math.degrees(math.atan2(kz, kx)) % 180.0
    return {"symbol": max(rates), "xi2_lambda_max": float(xi**2 * lam(np.array([angle]))[0]),
            "xi": xi, "angle_deg": angle}


def mode_growth(rheology, theta, n=64, k=0.9, eps=1e-8, material=None) -> dict:
    """Measured growth rate of the mode2d perturbation on n^2 cells.

    The amplitude is the x-Fourier component k_x of (u, w) (the wave's own, so that the
    grid-scale waves an ill-posed law amplifies from round-off are not counted), its
    log-slope fitted over the second half of the snapshots reached.
    """
    from ..api import run
    from ..cells.plane2d.scenes import Mode2DScene

    scene = Mode2DScene(theta=theta, k=k, eps=eps)
    pred = predicted_growth(rheology, scene, material)
    t_end = float(f"{min(8.0 / abs(pred['symbol']), 10.0):.4g}")
    times = [f"{t:.6g}" for t in np.linspace(0.0, t_end, 17)]
    result = finished(run(rheology, scene, (n, n), t_end, times, series_times=[], method="CVODE", rtol=1e-9,
                          atol=1e-14))
    m = int(round(scene.wave_vector()[0] * scene.L / (2 * np.pi)))
    z = result.z[..., 1]
    amp = [float(np.sqrt(np.sum(np.abs(np.fft.fft(result.u[i] - z / scene.H, axis=0)[m]) ** 2
                                + np.abs(np.fft.fft(result.w[i], axis=0)[m]) ** 2)))
           for i in range(len(result.times))]
    half = len(amp) // 2
    slope = float(np.polyfit(result.times[half:], np.log(amp[half:]), 1)[0])
    return {"rheology": rheology, "theta": theta, "N": n, "k": k, "measured": slope, **pred,
            "rel_error": abs(slope - pred["symbol"]) / abs(pred["symbol"]), "blew_up": result.blew_up}


def _growth_run(case: dict) -> dict:
    """One wave of :func:`growth_study` (a task)."""
    return mode_growth(case["rheology"], case["theta"], n=case["n"], eps=1e-6)


def growth_study(angles=(0.0, 45.0, 90.0, 135.0), n=32, path=DATA / "mode_growth.json", *, jobs=1, client=None,
                 progress=False, cache=None) -> dict:
    """Measured growth of mode2d waves against the symbol, both rheologies, at `angles`.

    The waves run in `jobs` worker processes or as tasks of the dask `client` (neither: here);
    with `cache` (a folder) each finished wave is kept there and not run again (:func:`run_cached`)."""
    cases = [dict(rheology=rheology, theta=theta, n=n) for rheology in ("icidr", "mui") for theta in angles]
    rows = []
    for row in run_cached(_growth_run, cases, cache, "sim2d.growth", jobs=jobs, progress=progress, desc="waves",
                          client=client, init_here=False):
        rows.append(row)
        print(f"{row['rheology']} theta = {row['theta']:g}: measured {row['measured']:.4g}, "
              f"symbol {row['symbol']:.4g}", flush=True)
    payload = {"scene": "mode2d", "N": n, "rows": rows, "command": "icidr-pde study sim2d growth"}
    write_json(payload, path)
    return payload


def growth_table(payload: dict) -> str:
    lines = ["| rheology | theta (deg) | wave angle (deg) | xi | measured rate | symbol max Re eig A | xi² Λ_max(θ) | run |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in payload["rows"]:
        lines.append(f"| {r['rheology']} | {r['theta']:g} | {r['angle_deg']:.1f} | {r['xi']:.3f} | {r['measured']:.4g} | "
                     f"{r['symbol']:.4g} | {r['xi2_lambda_max']:.4g} | {'fails' if r['blew_up'] else 'ok'} |")
    return "\n".join(lines)
