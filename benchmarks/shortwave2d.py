"""Growth of the short x-waves of iCIDR bump2d against the grid, the advection scheme and the BDF order.

For each N^2 (``--sizes``) and advection scheme (``--advection``), one ``icidr_pde.api.run`` of
iCIDR on bump2d at the default accuracy (CVODE rtol 1e-5, atol 1e-8, the default linear solver and
BDF order, or ``--max-order``), snapshots at ``--times`` (default 5 and 9). For each field phi, w
and each x-wave number k (the domain's length L = 30 holds k wavelengths), the growth rate of the
amplitude a_k over the whole cell and over the rows next to the moving wall
(:mod:`icidr_pde.studies.short_waves`; a wave at round-off has none: '-'). The bump itself lives
in k <= 16. The steps the run took are printed with it (docs/scaling.md).

Beside the measured rates, the continuum's (``--continuum``, on by default): the largest growth
rate max Re lambda of the 2-D equations linearized about the x-average of the first snapshot, per
x-wave number k, Chebyshev collocation in z with ``--points`` points (:mod:`stability.linear2d`).
``--rheology`` names the law(s) linearized about that base state (the run itself is always
iCIDR): 'icidr' (well-posed, bounded rates) and/or 'mui' (ill-posed, rates growing like k^2).

    nice -n 5 python benchmarks/shortwave2d.py --sizes 256 512 [--advection central upwind] [--json F]
    nice -n 10 python benchmarks/shortwave2d.py --sizes 64 128 --rheology icidr mui [--no-continuum]
"""

import argparse
import sys
import time

import numpy as np

from icidr_pde.studies.short_waves import SHORT, amplitudes, growth_rates, wall_rows

from provenance import write_json

WAVES = (4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)
#: the continuum damps every x-wave of iCIDR; a measured rate above it by more than this is the scheme's
MARGIN = 0.05


def continuum_rates(first_snapshot, ks, rheologies, points: int, H: float = 30.0, L: float = 30.0) -> dict:
    """{rheology: {k: max Re lambda}} of :mod:`stability.linear2d` about the x-average of a snapshot (3, Nx, Nz)."""
    from stability import linear2d

    base = linear2d.from_snapshot(first_snapshot, H=H, V0=1.0)
    out = {}
    for name in rheologies:
        op = linear2d.Linear2D(name, base, L, points)
        out[name] = {str(k): op.rate(k) for k in ks}
    return out


def measure(n: int, advection: str, times, rheologies=(), points: int = 192, max_order=None) -> dict:
    from icidr_pde import run
    from icidr_pde.scenes import get_scene

    scene = get_scene("bump2d")
    r = run("icidr", "bump2d", (n, n), float(times[-1]), [f"{t:g}" for t in times], series_times=[],
            advection=advection, max_order=max_order)
    d = r.to_dict()
    row = {"N": n, "advection": advection, "max_order": r.settings["max_order"], "times": list(times),
           "n_steps": d.get("n_steps"), "reason": r.reason}
    waves = [k for k in WAVES if k <= n // 2]
    for name in ("phi", "w"):
        snaps = np.asarray(getattr(r, name))
        a1 = amplitudes(snaps[-1])
        cell = growth_rates(snaps, times, waves=waves)
        wall = growth_rates(snaps, times, wall_rows(n), waves=waves)
        row[name] = {str(k): {"amplitude": float(a1[k]), "rate": cell.get(k), "rate_wall": wall.get(k)} for k in waves}
    if rheologies:
        first = np.stack([np.asarray(getattr(r, f))[0] for f in ("phi", "u", "w")])
        start = time.perf_counter()
        row["continuum"] = continuum_rates(first, waves, rheologies, points, H=scene.H, L=scene.L)
        row["continuum_points"] = points
        row["continuum_base_time"] = times[0]
        row["continuum_seconds"] = time.perf_counter() - start
    return row


def _rate(value) -> str:
    return "-" if value is None else f"{value:+.3f}"


def above_continuum(row) -> list:
    """The (field, k, region) whose measured rate exceeds the iCIDR continuum's by more than MARGIN:
    every k over the whole cell, the short waves (k >= SHORT) next to the wall (the bump's own waves
    spread toward it: their rate there is not an eigen-rate, :mod:`icidr_pde.studies.short_waves`)."""
    if "icidr" not in row.get("continuum", {}):
        return []
    bound = {k: v + MARGIN for k, v in row["continuum"]["icidr"].items()}
    return [(name, k, region) for name in ("phi", "w") for k, v in row[name].items()
            for region in ("rate", "rate_wall") if v[region] is not None and v[region] > bound[k]
            and (region == "rate" or int(k) >= SHORT)]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    parser.add_argument("--advection", nargs="+", default=["central"], choices=("central", "upwind"))
    parser.add_argument("--times", type=float, nargs="+", default=[5.0, 9.0])
    parser.add_argument("--json", default=None, help="also write the rows to this JSON file")
    parser.add_argument("--continuum", action=argparse.BooleanOptionalAction, default=True,
                        help="also the linearized continuum's rate per k about the first snapshot's x-average")
    parser.add_argument("--rheology", nargs="+", default=["icidr"], choices=("icidr", "mui"),
                        help="law(s) of the continuum rates (the run is iCIDR)")
    parser.add_argument("--points", type=int, default=192, help="Chebyshev points in z of the continuum rates")
    parser.add_argument("--max-order", type=int, default=None, help="CVODE's highest BDF order (default: the cell's)")
    args = parser.parse_args()
    rheologies = args.rheology if args.continuum else []
    rows = []
    for n in args.sizes:
        for advection in args.advection:
            row = measure(n, advection, args.times, rheologies, args.points, args.max_order)
            rows.append(row)
            print(f"{n}^2 {advection}, BDF orders <= {row['max_order']}: {row['n_steps']} steps, {row['reason']}; "
                  f"rates over t = {args.times[0]:g}..{args.times[-1]:g} (whole cell / next to the moving wall)")
            header = f"{'k':>4} {'phi':>15} {'w':>15} {'amplitude phi':>14}"
            if rheologies:
                header += " " + " ".join(f"{'continuum ' + r:>16}" for r in rheologies)
                print(f"  continuum: max Re lambda about the x-average at t = {args.times[0]:g} "
                      f"({args.points} Chebyshev points, {row['continuum_seconds']:.1f} s)")
            print("  " + header)
            for k in row["phi"]:
                line = "  " + f"{k:>4} " + " ".join(
                    f"{_rate(row[f][k]['rate']) + ' / ' + _rate(row[f][k]['rate_wall']):>15}" for f in ("phi", "w"))
                line += f" {row['phi'][k]['amplitude']:>14.1e}"
                if rheologies:
                    line += " " + " ".join(f"{row['continuum'][r][k]:>+16.5g}" for r in rheologies)
                print(line)
            if rheologies:
                above = above_continuum(row)
                row["above_continuum"] = above
                print(f"  measured rates above the iCIDR continuum + {MARGIN}: " + (", ".join(map(str, above)) or "none"))
    if args.json:
        command = "python benchmarks/shortwave2d.py " + " ".join(sys.argv[1:])
        write_json(args.json, {"rows": rows, "command": command})


if __name__ == "__main__":
    main()
