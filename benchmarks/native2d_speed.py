"""The 2-D cell on the native engine against the py-pde CVODE path: iCIDR bump2d to t = 10.

For each grid N^2 (default 32, 64, 128) runs the command line as whole processes (imports, kernel
loading included), the default accuracy, ``--engine native`` (CVODE BDF + GMRES(20) without a
preconditioner, eps_lin = KRYLOV_EPS_LIN) and ``--engine pde`` (the py-pde path's default: the same
GMRES preconditioned by the x-averaged Jacobian, :mod:`icidr_pde.engines.linear.xfourier_inverse`; the baseline), and
prints process and solve time (JSON ``wall_s``) and the process's CPU time (user + system, wait4:
less disturbed by other work on a shared machine), their ratios native / pde, and beside them the
accuracy figure: the largest relative difference of max_w and l2_velocity at t = 0.5, 1, 2, 5, 10
between the two runs (solver A against solver B at the same tolerances).

Then the right-hand side alone, time per call, best of repeats, at the initial state: the C kernel
printed from templates/cartesian2d.py (timed in C, the library's flags
``icidr_pde.native.build.LIBRARY_FLAGS`` plus an inlined law) against numba's kernel of the same
template (timed from Python through its dispatcher), with the largest relative difference of the rates.

    nice -n 10 python benchmarks/native2d_speed.py [--sizes 32 64 128] [--rhs-sizes 32 64 128]
"""

import argparse
import os
import sys
import timeit

from sim2d_speed import TIMES, cli_run  # the same CLI process and output times as the 2-D speed benchmark
from provenance import write_json

QUANTITIES = ("max_w", "l2_velocity")


def whole_process(n: int, engine: str) -> dict:
    wall, usage, result = cli_run(n, ["--engine", engine])
    if result["settings"]["engine"] != ("native" if engine == "native" else "sundae"):
        raise RuntimeError(f"--engine {engine} ran on {result['settings']['engine']}")
    return {"process_s": wall, "process_cpu_s": usage.ru_utime + usage.ru_stime, "solve_s": result["wall_s"],
            "solve_cpu_s": result.get("cpu_s"), "n_steps": result["n_steps"], "n_rhs": result["n_rhs"],
            **{q: result[q] for q in QUANTITIES}}


def difference(a: dict, b: dict) -> float:
    return max(abs(a[q][t] - b[q][t]) / abs(b[q][t]) for q in QUANTITIES for t in TIMES)


def rhs_times(n: int) -> dict:
    import numpy as np

    from icidr_pde.case import build_case
    from icidr_pde.native_case import Plane2DCase

    native = Plane2DCase("icidr", "bump2d", (n, n))
    problem = native.problem()
    case = build_case("icidr", "bump2d", "fv2d", (n, n))
    pde = case.pde
    kernel, ghost = pde._loops().rates, pde.ghost_coefficients(case.grid)
    (hx, hz), params = case.grid.discretization, pde.material.params
    data = np.ascontiguousarray(case.state.data)
    out = np.empty_like(data)
    kernel(data, ghost, hx, hz, False, params, out)
    number = max(10, int(2e5 / n**2))
    numba_s = min(timeit.repeat(lambda: kernel(data, ghost, hx, hz, False, params, out), number=number, repeat=7)) / number
    c_s = min(problem.kernel_times(native.y0, number)[0] for _ in range(7))
    diff = float(np.max(np.abs(problem.rates(native.y0) - out.ravel())) / np.max(np.abs(out)))
    return {"c_us": 1e6 * c_s, "numba_us": 1e6 * numba_s, "max_rel_diff": diff}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[32, 64, 128])
    parser.add_argument("--rhs-sizes", type=int, nargs="*", default=[32, 64, 128])
    parser.add_argument("--json", default="data/benchmarks/native2d_speed.json")
    args = parser.parse_args()
    whole(args.sizes, rows := {})
    rhs = {n: rhs_times(n) for n in args.rhs_sizes}
    print("\n| grid | C RHS [us] | numba RHS [us] | C / numba | max rel. difference of the rates |")
    print("| --- | --- | --- | --- | --- |")
    for n, r in rhs.items():
        print(f"| {n}² | {r['c_us']:.0f} | {r['numba_us']:.0f} | {r['c_us'] / r['numba_us']:.2f} | {r['max_rel_diff']:.1e} |")
    write_json(args.json, {"runs": rows, "rhs": rhs, "load": os.getloadavg(),
                           "command": "nice -n 10 python benchmarks/native2d_speed.py " + " ".join(sys.argv[1:])})


def whole(sizes, rows):
    print("iCIDR bump2d to t = 10, default accuracy (difference: largest relative difference of max_w and "
          "l2_velocity at t = 0.5 ... 10, native against py-pde)")
    print("| grid | process native / py-pde [s] | ratio | process CPU native / py-pde [s] | ratio | "
          "solve native / py-pde [s] | ratio | steps native / py-pde | difference |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in sizes:
        native, pde = whole_process(n, "native"), whole_process(n, "pde")
        rows[n] = {"native": native, "pde": pde, "difference": difference(native, pde)}
        cells = [f"{native[k]:.2f} / {pde[k]:.2f} | {native[k] / pde[k]:.2f}" for k in ("process_s", "process_cpu_s", "solve_s")]
        print(f"| {n}² | {' | '.join(cells)} | {native['n_steps']} / {pde['n_steps']} | {rows[n]['difference']:.1e} |",
              flush=True)


if __name__ == "__main__":
    main()
