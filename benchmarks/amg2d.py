"""CVODE's Krylov solves of the 2-D cell with and without the AMG preconditioner: counters.

iCIDR bump2d to t = 10 (CVODE rtol 1e-5, atol 1e-8, the default accuracy) on N^2 cells, in
this process, once with ``jacobian='krylov'`` (GMRES, no preconditioner: the baseline) and once
with ``jacobian='amg'`` (GMRES + one algebraic-multigrid V-cycle, :mod:`icidr_pde.engines.linear.amg_hierarchy`).
For each: the solve's wall and CPU time, CVODE's steps, Newton iterations, GMRES iterations
(and per Newton iteration), right-hand-side calls (those of the difference-quotient Jacobian-vector products included), preconditioner set-ups (Jacobian and
aggregation rebuilt) and solves, the mass drift, and beside it the accuracy figure: the
largest relative difference of max|w| at t = 0.5 ... 10 between the two runs. Prints the
ratio of the solve times (krylov / amg) measured in this run, and the process's peak resident
memory after each run (the krylov run comes first: the amg figure is the larger of the two).

    nice -n 10 python benchmarks/amg2d.py [--sizes 64 128]
"""

import argparse
import resource
import time

from icidr_pde.api import run
from icidr_pde.engines import sundae

from provenance import write_json

TIMES = ["0.5", "1", "2", "5", "10"]
SOLVERS = ("krylov", "amg", "fourier")


def _counting():
    """Record CVODE's counters of the last engine whose counts the run path reads."""
    last = {}
    counts = sundae.CvodeEngine.counts

    def counting(self):
        if self.counters is not None:
            last.update(self.counters.all())
        return counts(self)

    sundae.CvodeEngine.counts = counting
    return last


def measure(n: int, jacobian: str, last: dict) -> dict:
    last.clear()
    cpu = time.process_time()
    r = run("icidr", "bump2d", (n, n), 10.0, TIMES, method="CVODE", rtol=1e-5, atol=1e-8, jacobian=jacobian,
            engine="pde")  # both on the py-pde path ('auto' takes the native engine for GMRES on small grids)
    cpu = time.process_time() - cpu
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    d = r.to_dict()
    return {"N": n, "jacobian": jacobian, "linear_solver": r.settings["linear_solver"], "solve_s": d["wall_s"],
            "cpu_s": cpu, "peak_rss_mb": peak, "reason": d["reason"], "mass_drift": d["mass_drift"], "max_w": d["max_w"],
            "n_rhs": d["n_rhs"], **last, "linear_per_newton": last["linear_iterations"] / last["newton_iterations"]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128])
    parser.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=SOLVERS,
                        help="Jacobian modes, the first the baseline of the ratios")
    parser.add_argument("--json", default="data/benchmarks/amg2d.json")
    args = parser.parse_args()
    last = _counting()
    run("icidr", "bump2d", (8, 8), 0.1, method="CVODE", jacobian="amg")  # kernels compiled or loaded
    rows = []
    print("| grid | linear solver | solve [s] | CPU [s] | steps | Newton | GMRES | GMRES / Newton | RHS | "
          "P set-ups (J) | P solves | mass drift | max|w| difference | peak RSS [MB] | solve ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in args.sizes:
        pair = [measure(n, jacobian, last) for jacobian in args.solvers]
        base = pair[0]
        for r in pair:
            r["max_w_difference"] = max(abs(r["max_w"][t] / base["max_w"][t] - 1) for t in TIMES)
            rows.append(r)
            print(f"| {n}² | {r['linear_solver']} | {r['solve_s']:.2f} | {r['cpu_s']:.2f} | {r['steps']} | "
                  f"{r['newton_iterations']} | {r['linear_iterations']} | {r['linear_per_newton']:.1f} | {r['n_rhs']} | "
                  f"{r['preconditioner_setups']} | {r['preconditioner_solves']} | {r['mass_drift']:.1e} | "
                  f"{r['max_w_difference']:.1e} | {r['peak_rss_mb']:.0f} | {base['solve_s'] / r['solve_s']:.2f} |", flush=True)
    write_json(args.json, {"rows": rows, "command": "nice -n 10 python benchmarks/amg2d.py --sizes "
                           + " ".join(map(str, args.sizes)) + " --solvers " + " ".join(args.solvers)})


if __name__ == "__main__":
    main()
