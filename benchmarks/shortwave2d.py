"""Growth of the short x-waves of iCIDR bump2d against the grid and the advection scheme.

For each N^2 (``--sizes``) and advection scheme (``--advection``), one ``icidr_pde.api.run`` of
iCIDR on bump2d at the default accuracy (CVODE rtol 1e-5, atol 1e-8, the default linear solver),
snapshots at ``--times`` (default 5 and 9). For each field phi, w and each x-wave number k
(the domain's length L = 30 holds k wavelengths), the amplitude
a_k(t) = || rfft_x(f - <f>_x)[k, :] ||_2 over z, and the growth rate
log(a_k(t1) / a_k(t0)) / (t1 - t0) between the first and last snapshot. The bump itself lives in
k <= 8; the integration error seeds every k at about the tolerance, so a positive rate at large k
is a growth the run resolves, not the initial condition. The steps the run took are printed with
it (docs/scaling.md).

Beside the measured rates, the continuum's (``--continuum``, on by default): the largest growth
rate max Re lambda of the 2-D equations linearized about the x-average of the first snapshot, per
x-wave number k, Chebyshev collocation in z with ``--points`` points (:mod:`stability.linear2d`).
``--rheology`` names the law(s) linearized about that base state (the run itself is always
iCIDR): 'icidr' (well-posed, bounded rates) and/or 'mui' (ill-posed, rates growing like k^2).

    nice -n 5 python benchmarks/shortwave2d.py --sizes 256 512 [--advection central upwind] [--json F]
    nice -n 10 python benchmarks/shortwave2d.py --sizes 64 128 --rheology icidr mui [--no-continuum]
"""

import argparse
import json
import pathlib
import sys
import time

import numpy as np

WAVES = (4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)


def amplitudes(field: np.ndarray) -> np.ndarray:
    """a_k of one snapshot (Nx, Nz): the z-norm of the x-spectrum of the departure from the x-mean."""
    return np.sqrt((np.abs(np.fft.rfft(field - field.mean(axis=0), axis=0)) ** 2).sum(axis=1))


def continuum_rates(first_snapshot, ks, rheologies, points: int, H: float = 30.0, L: float = 30.0) -> dict:
    """{rheology: {k: max Re lambda}} of :mod:`stability.linear2d` about the x-average of a snapshot (3, Nx, Nz)."""
    from stability import linear2d

    base = linear2d.from_snapshot(first_snapshot, H=H, V0=1.0)
    out = {}
    for name in rheologies:
        op = linear2d.Linear2D(name, base, L, points)
        out[name] = {str(k): op.rate(k) for k in ks}
    return out


def measure(n: int, advection: str, times, rheologies=(), points: int = 192) -> dict:
    from icidr_pde import run
    from icidr_pde.scenes import get_scene

    scene = get_scene("bump2d")
    r = run("icidr", "bump2d", (n, n), float(times[-1]), [f"{t:g}" for t in times], series_times=[],
            advection=advection)
    d = r.to_dict()
    row = {"N": n, "advection": advection, "times": list(times), "n_steps": d.get("n_steps"),
           "reason": r.reason}
    for name in ("phi", "w"):
        snaps = np.asarray(getattr(r, name))
        a0, a1 = amplitudes(snaps[0]), amplitudes(snaps[-1])
        row[name] = {str(k): {"amplitude": float(a1[k]), "rate": float(np.log(a1[k] / a0[k]) / (times[-1] - times[0]))}
                     for k in WAVES if k < a1.size}
    if rheologies:
        first = np.stack([np.asarray(getattr(r, f))[0] for f in ("phi", "u", "w")])
        ks = [int(k) for k in row["phi"]]
        start = time.perf_counter()
        row["continuum"] = continuum_rates(first, ks, rheologies, points, H=scene.H, L=scene.L)
        row["continuum_points"] = points
        row["continuum_base_time"] = times[0]
        row["continuum_seconds"] = time.perf_counter() - start
    return row


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
    args = parser.parse_args()
    rheologies = args.rheology if args.continuum else []
    rows = []
    for n in args.sizes:
        for advection in args.advection:
            row = measure(n, advection, args.times, rheologies, args.points)
            rows.append(row)
            print(f"{n}^2 {advection}: {row['n_steps']} steps, {row['reason']}")
            for name in ("phi", "w"):
                print(f"  {name} rate/amplitude at t = {args.times[-1]:g} by k: " + "  ".join(
                    f"{k}: {v['rate']:+.2f}/{v['amplitude']:.1e}" for k, v in row[name].items()))
            if rheologies:
                print(f"  continuum max Re lambda about the x-average at t = {args.times[0]:g} "
                      f"({args.points} Chebyshev points, {row['continuum_seconds']:.1f} s):")
                print("    " + f"{'k':>4} {'phi meas.':>10} {'w meas.':>10} " + " ".join(f"{r:>12}" for r in rheologies))
                for k in row["phi"]:
                    print("    " + f"{k:>4} {row['phi'][k]['rate']:+10.4f} {row['w'][k]['rate']:+10.4f} "
                          + " ".join(f"{row['continuum'][r][k]:+12.5g}" for r in rheologies))
    if args.json:
        path = pathlib.Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        command = "python benchmarks/shortwave2d.py " + " ".join(sys.argv[1:])
        path.write_text(json.dumps({"rows": rows, "command": command}, indent=1))


if __name__ == "__main__":
    main()
