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

    nice -n 5 python benchmarks/shortwave2d.py --sizes 256 512 [--advection central upwind] [--json F]
"""

import argparse
import json
import pathlib
import sys

import numpy as np

WAVES = (4, 8, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512)


def amplitudes(field: np.ndarray) -> np.ndarray:
    """a_k of one snapshot (Nx, Nz): the z-norm of the x-spectrum of the departure from the x-mean."""
    return np.sqrt((np.abs(np.fft.rfft(field - field.mean(axis=0), axis=0)) ** 2).sum(axis=1))


def measure(n: int, advection: str, times) -> dict:
    from icidr_pde import run

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
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    parser.add_argument("--advection", nargs="+", default=["central"], choices=("central", "upwind"))
    parser.add_argument("--times", type=float, nargs="+", default=[5.0, 9.0])
    parser.add_argument("--json", default=None, help="also write the rows to this JSON file")
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        for advection in args.advection:
            row = measure(n, advection, args.times)
            rows.append(row)
            print(f"{n}^2 {advection}: {row['n_steps']} steps, {row['reason']}")
            for name in ("phi", "w"):
                print(f"  {name} rate/amplitude at t = {args.times[-1]:g} by k: " + "  ".join(
                    f"{k}: {v['rate']:+.2f}/{v['amplitude']:.1e}" for k, v in row[name].items()))
    if args.json:
        path = pathlib.Path(args.json)
        path.parent.mkdir(parents=True, exist_ok=True)
        command = "python benchmarks/shortwave2d.py " + " ".join(sys.argv[1:])
        path.write_text(json.dumps({"rows": rows, "command": command}, indent=1))


if __name__ == "__main__":
    main()
