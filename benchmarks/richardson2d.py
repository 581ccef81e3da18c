"""Observed order and error of iCIDR bump2d against a Richardson extrapolation of our own runs.

For each advection scheme (central, the 2-D default, and upwind) the measures max_w,
max_phi_dev and l2_velocity at t = 0.5 ... 10 on 64^2, 96^2 and 128^2 (the 64^2 and 128^2
values from data/sim2d/convergence.json and convergence_upwind.json, 96^2 run here with the
studies' settings) are fitted by q(N) = q_inf + C N^(-p) (three grids, three unknowns: p from
the ratio of successive differences, then q_inf); the table gives p and the relative error
|q_N - q_inf| / |q_inf| of each grid. Writes data/sim2d/richardson.json.

    nice -n 5 python benchmarks/richardson2d.py
"""

import argparse
import json
import pathlib
import sys

from scipy.optimize import brentq

from icidr_pde.api import run
from icidr_pde.studies.sim2d import QUANTITIES, SETTINGS, SOLVER_2D, TIMES

from provenance import write_json

DATA = pathlib.Path("data") / "sim2d"
SIZES = (64, 96, 128)
STUDIES = {"central": DATA / "convergence.json", "upwind": DATA / "convergence_upwind.json"}


def fit(values, sizes=SIZES):
    """(p, q_inf) of q = q_inf + C N^-p through three grids; None where the differences change sign."""
    (a, b, c), (n1, n2, n3) = values, sizes
    ratio = (a - b) / (b - c) if b != c else None
    if ratio is None or ratio <= 0:
        return None, None

    def mismatch(p):
        return (n1**-p - n2**-p) / (n2**-p - n3**-p) - ratio

    try:
        p = brentq(mismatch, 0.05, 8.0)
    except ValueError:
        return None, None
    C = (a - c) / (n1**-p - n3**-p)
    return p, c - C * n3**-p


def main() -> int:
    # no options: the parser answers --help (and refuses anything else) instead of running the study
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    out = {"sizes": list(SIZES), "times": list(TIMES), "settings": SETTINGS, "schemes": {},
           "command": "python benchmarks/richardson2d.py"}
    for scheme, path in STUDIES.items():
        study = json.loads(path.read_text())["runs"]
        r96 = run("icidr", "bump2d", (96, 96), float(TIMES[-1]), list(TIMES), advection=scheme, **SOLVER_2D, **SETTINGS).to_dict()
        runs = {"64": study["64"], "96": r96, "128": study["128"]}
        rows = {}
        for q in QUANTITIES:
            rows[q] = {}
            for t in TIMES:
                vals = [runs[str(n)][q][t] for n in SIZES]
                p, q_inf = fit(vals)
                rows[q][t] = {"values": vals, "order": p, "q_inf": q_inf,
                              "rel_error": None if q_inf is None else [abs(v - q_inf) / abs(q_inf) for v in vals]}
        out["schemes"][scheme] = rows
        print(f"{scheme}: 96^2 {r96['wall_s']:.1f} s", flush=True)
    for scheme, rows in out["schemes"].items():
        print(f"\n{scheme}")
        print("| measure | t | order p (64², 96², 128²) | error 64² | error 96² | error 128² |")
        print("| --- | --- | --- | --- | --- | --- |")
        for q in QUANTITIES:
            for t in TIMES:
                r = rows[q][t]
                errs = " | ".join("–" if r["rel_error"] is None else f"{e:.2%}" for e in (r["rel_error"] or [None] * 3))
                p = "–" if r["order"] is None else f"{r['order']:.2f}"
                print(f"| {q} | {t} | {p} | {errs} |")
    write_json(DATA / "richardson.json", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
