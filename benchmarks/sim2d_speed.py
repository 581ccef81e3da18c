"""Speed of the 2-D shear cell: iCIDR on bump2d to t = 10, whole process and solve.

For each grid N^2 (default 32, 64; 128 and 256 with the fast path only) runs, as separate whole
processes of the command line (imports, kernel loading or compilation included),

* the fast path: ``--method CVODE`` (SUNDIALS BDF, matrix-free GMRES Krylov solver) with the
  2-D default advection (central, second order);
* the same with ``--advection upwind`` (first order, the default before issue 23);
* the same with ``--jacobian amg`` (GMRES preconditioned by one algebraic-multigrid V-cycle on
  I - gamma J, :mod:`icidr_pde.engines.amg`);
* the baseline: ``--method BDF --jacobian colored-fd`` (scipy's BDF with a sparse
  finite-difference Jacobian, colored, well-scaled increments, SuperLU);

and a reference on the same grid (CVODE, rtol 1e-8, atol 1e-11; 1e-7, 1e-10 on the
--fast-only grids) for the accuracy figure
beside each timing: the largest error of max_w, max_phi_dev and l2_velocity at
t = 0.5, 1, 2, 5, 10 relative to the reference value (the time-integration error), and the
grid error: the largest relative error of max_w at those times against the Richardson
extrapolation of data/sim2d/richardson.json (benchmarks/richardson2d.py, central scheme). Wall time of the process and of
the solve (JSON ``wall_s``), peak resident memory of the process (wait4's ru_maxrss).
Prints a table and the ratio baseline/fast measured in this run; writes
data/benchmarks/sim2d_speed.json.

    nice -n 10 python benchmarks/sim2d_speed.py [--sizes 32 64] [--fast-only 128 256]
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

TIMES = ["0.5", "1", "2", "5", "10"]
QUANTITIES = ("max_w", "max_phi_dev", "l2_velocity")
#: the CVODE configurations on the py-pde path ('auto' takes the native engine on small grids:
#: benchmarks/native2d_speed.py compares the two)
CONFIGS = {
    "fast": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--engine", "pde"],
    "fast-upwind": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--advection", "upwind", "--engine", "pde"],
    "fast-amg": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--jacobian", "amg", "--engine", "pde"],
    "baseline": ["--method", "BDF", "--jacobian", "colored-fd", "--rtol", "1e-5", "--atol", "1e-8"],
    "reference": ["--method", "CVODE", "--rtol", "1e-8", "--atol", "1e-11", "--engine", "pde"],
    "reference-fast-only": ["--method", "CVODE", "--rtol", "1e-7", "--atol", "1e-10", "--engine", "pde"],  # cheaper, for 256^2
}
LABELS = {"fast": "CVODE, GMRES, central", "fast-upwind": "CVODE, GMRES, upwind",
          "fast-amg": "CVODE, GMRES + AMG, central",
          "baseline": "scipy BDF, colored sparse FD J"}
RICHARDSON = pathlib.Path("data") / "sim2d" / "richardson.json"


def cli_run(n: int, options, times=TIMES):
    """One CLI process of iCIDR bump2d on n^2 cells to t = 10 with `options`: (wall time,
    its rusage from wait4, the JSON it wrote)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "out.json"
        cmd = [sys.executable, "-m", "icidr_pde.cli", "run", "--scene", "bump2d", "--rheology", "icidr",
               "--Nx", str(n), "--Nz", str(n), "--t-end", "10", "--times", *times, "--no-progress",
               "--json", str(out), *options]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        stderr = proc.stderr.read().decode()
        proc.stderr.close()
        if os.waitstatus_to_exitcode(status) != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{stderr}")
        return wall, usage, json.loads(out.read_text())


def whole_process(n: int, config: str) -> dict:
    """Run one CLI process; return its wall time, peak RSS and the JSON it wrote."""
    wall, usage, result = cli_run(n, CONFIGS[config])
    return {"process_s": wall, "max_rss_mb": usage.ru_maxrss / 1024, "solve_s": result["wall_s"],
            "compile_s": result["compile_s"], "n_rhs": result["n_rhs"], "n_jac": result["n_jac"],
            "n_steps": result["n_steps"], "linear_solver": result["settings"]["linear_solver"],
            **{q: result[q] for q in QUANTITIES}}


def error(run: dict, ref: dict) -> float:
    """Largest relative error of the measures at the requested times against the reference."""
    return max(abs(run[q][t] - ref[q][t]) / abs(ref[q][t]) for q in QUANTITIES for t in TIMES)


def grid_error(run: dict) -> float | None:
    """Largest relative error of max_w at the times against the Richardson limit (None: no limit)."""
    if not RICHARDSON.exists():
        return None
    rows = json.loads(RICHARDSON.read_text())["schemes"]["central"]["max_w"]
    errors = [abs(run["max_w"][t] - rows[t]["q_inf"]) / abs(rows[t]["q_inf"]) for t in TIMES
              if rows[t]["q_inf"] is not None]
    return max(errors) if errors else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[32, 64])
    parser.add_argument("--fast-only", type=int, nargs="*", default=[128, 256],
                        help="grids timed with the fast path only (the baseline takes > 10 min at 128^2)")
    parser.add_argument("--json", default="data/benchmarks/sim2d_speed.json")
    args = parser.parse_args()
    rows = []
    for n in args.sizes + args.fast_only:
        ref = whole_process(n, "reference" if n not in args.fast_only else "reference-fast-only")
        row = {"N": n, "reference": ref}
        configs = ("fast", "fast-upwind", "fast-amg") + (() if n in args.fast_only else ("baseline",))
        for config in configs:
            row[config] = whole_process(n, config)
            row[config]["error"] = error(row[config], ref) if config != "fast-upwind" else None
            row[config]["grid_error"] = grid_error(row[config])
            print(f"{n}^2 {config}: {row[config]['process_s']:.1f} s process, {row[config]['solve_s']:.2f} s solve, "
                  f"{row[config]['max_rss_mb']:.0f} MB, error {row[config]['error'] or 0:.1e}, "
                  f"grid error {row[config]['grid_error'] or 0:.1e}", flush=True)
        rows.append(row)
    print("\niCIDR bump2d to t = 10 (error: largest relative error of max_w, max_phi_dev, l2_velocity at "
          "t = 0.5 ... 10 against CVODE rtol 1e-8 on the same grid)")
    print("| grid | method | process [s] | solve [s] | peak RSS [MB] | error | grid error max_w | solve ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in rows:
        for config, label in LABELS.items():
            if config not in row:
                continue
            r = row[config]
            ratio = r["solve_s"] / row["fast"]["solve_s"]
            err = "–" if r["error"] is None else f"{r['error']:.1e}"
            gerr = "–" if r["grid_error"] is None else f"{r['grid_error']:.1%}"
            print(f"| {row['N']}² | {label} | {r['process_s']:.1f} | {r['solve_s']:.2f} | {r['max_rss_mb']:.0f} | "
                  f"{err} | {gerr} | {ratio:.1f} |")
    path = pathlib.Path(args.json)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps({"rows": rows, "configs": CONFIGS, "times": TIMES,
                               "command": "nice -n 10 python benchmarks/sim2d_speed.py " + " ".join(sys.argv[1:])},
                              indent=1))
    os.replace(tmp, path)


if __name__ == "__main__":
    main()
