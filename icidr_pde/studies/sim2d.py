"""Studies of the 2-D shear cell (scene ``bump2d``), their tables, field images and movie.

``python -m icidr_pde.studies.sim2d convergence`` -- iCIDR on bump2d at 16^2 .. 128^2: max_w,
max_phi_dev, l2_velocity at t = 0.5, 1, 2, 5, 10 and the observed orders
(data/sim2d/convergence.json);
``python -m icidr_pde.studies.sim2d tstar`` -- mu(I),Phi(I) on bump2d at 16^2 .. 128^2: the
failure time t* of every 2-D grid beside the 1-D finite-volume run of the same perturbation
made x-independent (w = eps ((z - H/2)/ell) exp(-(z - H/2)^2/ell^2)) at N = Nz
(data/sim2d/tstar.json);
``python -m icidr_pde.studies.sim2d growth`` -- mode2d waves at several angles, the measured
growth rate against the symbol of :mod:`stability.directional` (data/sim2d/mode_growth.json);
``python -m icidr_pde.studies.sim2d tables`` -- the tables of docs/sim2d.md from those files.

The field images and the movie of docs/sim2d.md are drawn by :mod:`icidr_pde.figures.sim2d_fields`.

Every run goes through :func:`icidr_pde.api.run` (one case builder, one run path).
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys

import numpy as np

from ..outputs import write_json

__all__ = ["convergence_study", "tstar_study", "growth_study", "convergence_table", "tstar_table", "growth_table",
           "observed_orders", "mode_growth", "predicted_growth", "SETTINGS"]

TIMES = ("0.5", "1", "2", "5", "10")
SIZES = (16, 32, 64, 128)
QUANTITIES = ("max_w", "max_phi_dev", "l2_velocity")
DATA = pathlib.Path("data") / "sim2d"
#: integrator settings of the studies (CVODE, matrix-free GMRES; tolerances well below the grid errors)
SETTINGS = dict(method="CVODE", rtol=1e-7, atol=1e-10)


def observed_orders(values: list[float]) -> list[float | None]:
    """log2 of successive difference ratios |q_N - q_2N| / |q_2N - q_4N| (grids doubling)."""
    out = []
    for a, b, c in zip(values, values[1:], values[2:]):
        d1, d2 = abs(a - b), abs(b - c)
        out.append(math.log2(d1 / d2) if d1 > 0 and d2 > 0 else None)
    return out


def convergence_study(sizes=SIZES, times=TIMES, path=DATA / "convergence.json", **settings) -> dict:
    """iCIDR on bump2d at Nx = Nz = N for each N in `sizes`; the JSON of each run plus orders."""
    from ..api import run

    settings = {**SETTINGS, **settings}
    runs = {}
    for n in sizes:
        result = run("icidr", "bump2d", (n, n), float(times[-1]), list(times), **settings)
        runs[str(n)] = {k: v for k, v in result.to_dict().items()
                        if k in ("Nx", "Nz", "L", "blew_up", "reason", "mass_drift", "wall_s", "n_rhs",
                                 *QUANTITIES)}
        print(f"iCIDR bump2d {n}x{n}: {result}", flush=True)
    orders = {q: {t: observed_orders([runs[str(n)][q][t] for n in sizes]) for t in times} for q in QUANTITIES}
    payload = {"scene": "bump2d", "rheology": "icidr", "sizes": list(sizes), "times": list(times),
               "settings": settings, "runs": runs, "observed_orders": orders,
               "command": "python -m icidr_pde.studies.sim2d convergence"}
    write_json(payload, path)
    return payload


def tstar_study(sizes=(16, 24, 32, 48, 64, 96, 128), t_end=10.0, path=DATA / "tstar.json", **settings) -> dict:
    """mu(I),Phi(I) on bump2d (2-D) and its x-independent perturbation (1-D fd) at N = Nz."""
    from ..api import run
    from ..scenes2d import Bump2DScene

    settings = {**SETTINGS, **settings}
    scene = Bump2DScene()
    rows = []
    for n in sizes:
        r2 = run("mui", "bump2d", (n, n), t_end, ["0", f"{t_end:g}"], series_times=[], **settings)
        r1 = run("mui", scene.x_independent(), n, t_end, ["0", f"{t_end:g}"], discretization="fd",
                 series_times=[], **settings)
        rows.append({"N": n, "t_star_2d": r2.t_star, "reason_2d": r2.reason, "t_star_1d": r1.t_star,
                     "reason_1d": r1.reason, "max_w_1d_end": None if r1.blew_up else float(np.max(np.abs(r1.final[2])))})
        print(f"mu(I) bump2d N = {n}: 2-D {r2}; 1-D {r1}", flush=True)
    payload = {"scene": "bump2d", "rheology": "mui", "t_end": t_end, "settings": settings, "rows": rows,
               "command": "python -m icidr_pde.studies.sim2d tstar"}
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
    from ..scenes2d import Mode2DScene

    scene = Mode2DScene(theta=theta, k=k, eps=eps)
    pred = predicted_growth(rheology, scene, material)
    t_end = float(f"{min(8.0 / abs(pred['symbol']), 10.0):.4g}")
    times = [f"{t:.6g}" for t in np.linspace(0.0, t_end, 17)]
    result = run(rheology, scene, (n, n), t_end, times, series_times=[], method="CVODE", rtol=1e-9, atol=1e-14)
    m = int(round(scene.wave_vector()[0] * scene.L / (2 * np.pi)))
    z = result.z[..., 1]
    amp = [float(np.sqrt(np.sum(np.abs(np.fft.fft(result.u[i] - z / scene.H, axis=0)[m]) ** 2
                                + np.abs(np.fft.fft(result.w[i], axis=0)[m]) ** 2)))
           for i in range(len(result.times))]
    half = len(amp) // 2
    slope = float(np.polyfit(result.times[half:], np.log(amp[half:]), 1)[0])
    return {"rheology": rheology, "theta": theta, "N": n, "k": k, "measured": slope, **pred,
            "rel_error": abs(slope - pred["symbol"]) / abs(pred["symbol"]), "blew_up": result.blew_up}


def growth_study(angles=(0.0, 45.0, 90.0, 135.0), n=32, path=DATA / "mode_growth.json") -> dict:
    """Measured growth of mode2d waves against the symbol, both rheologies, at `angles`."""
    rows = []
    for rheology in ("icidr", "mui"):
        for theta in angles:
            row = mode_growth(rheology, theta, n=n, eps=1e-6)
            rows.append(row)
            print(f"{rheology} theta = {theta:g}: measured {row['measured']:.4g}, symbol {row['symbol']:.4g}", flush=True)
    payload = {"scene": "mode2d", "N": n, "rows": rows, "command": "python -m icidr_pde.studies.sim2d growth"}
    write_json(payload, path)
    return payload


def growth_table(payload: dict) -> str:
    lines = ["| rheology | theta (deg) | wave angle (deg) | xi | measured rate | symbol max Re eig A | xi² Λ_max(θ) | run |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in payload["rows"]:
        lines.append(f"| {r['rheology']} | {r['theta']:g} | {r['angle_deg']:.1f} | {r['xi']:.3f} | {r['measured']:.4g} | "
                     f"{r['symbol']:.4g} | {r['xi2_lambda_max']:.4g} | {'fails' if r['blew_up'] else 'ok'} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icidr_pde.studies.sim2d", description=__doc__.split("\n")[0])
    parser.add_argument("study", choices=["convergence", "tstar", "growth", "tables"])
    parser.add_argument("--sizes", type=int, nargs="+", default=None)
    args = parser.parse_args(argv)
    if args.study == "convergence":
        convergence_study(**({"sizes": tuple(args.sizes)} if args.sizes else {}))
    elif args.study == "tstar":
        tstar_study(**({"sizes": tuple(args.sizes)} if args.sizes else {}))
    elif args.study == "growth":
        growth_study()
    else:
        print(convergence_table(json.loads((DATA / "convergence.json").read_text())))
        print()
        print(tstar_table(json.loads((DATA / "tstar.json").read_text())))
        print()
        print(growth_table(json.loads((DATA / "mode_growth.json").read_text())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
