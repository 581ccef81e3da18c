"""Speed of the 2-D shear cell: iCIDR on bump2d to t = 10, whole process and solve.

For each grid N^2 (default 32, 64; 128 and 256 without the baseline; --large grids with the
default alone) runs, as separate whole processes of the command line (imports, kernel loading or
compilation included), all on the py-pde path (``--engine pde``; 'auto' takes the native engine
to 64^2: benchmarks/native2d_speed.py compares the two),

* the default: ``--method CVODE`` (SUNDIALS BDF, orders up to 2: A-stable, docs/sim2d.md) with GMRES
  preconditioned by the x-averaged Jacobian (:mod:`icidr_pde.engines.linear.xfourier_inverse`), the 2-D default
  advection (central, second order);
* the default with BDF orders up to 5 (``--max-order 5``, the default before issue 37: fewer steps,
  but it amplifies the short advected x-waves);
* GMRES without a preconditioner (``--jacobian krylov``, the default before it);
* the default with ``--advection upwind`` (first order, the default before issue 23);
* GMRES preconditioned by one algebraic-multigrid V-cycle (``--jacobian amg``, :mod:`icidr_pde.engines.linear.amg_hierarchy`);
* the baseline: ``--method BDF --jacobian colored-fd`` (scipy's BDF with a sparse
  finite-difference Jacobian, colored, well-scaled increments, SuperLU);

and a reference on the same grid (the default at rtol 1e-8, atol 1e-11; 1e-7, 1e-10 on the
--fast-only and --large grids, none with --no-large-reference) for the accuracy figure
beside each timing: the largest error of max_w, max_phi_dev and l2_velocity at
t = 0.5, 1, 2, 5, 10 relative to the reference value (the time-integration error), and the
grid error: the largest relative error of max_w at those times against the Richardson
extrapolation of data/sim2d/richardson.json (benchmarks/richardson2d.py, central scheme). Wall time of the process and of
the solve (JSON ``wall_s``), peak resident memory of the process (wait4's ru_maxrss).
Prints a table and the ratio baseline/fast measured in this run; writes
data/benchmarks/sim2d_speed.json.

    nice -n 10 python benchmarks/sim2d_speed.py [--sizes 32 64] [--fast-only 128 256] [--large 512 1024]

A run longer than --timeout seconds is stopped and reported as not finished.
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import threading
import time

from provenance import write_json

TIMES = ["0.5", "1", "2", "5", "10"]
QUANTITIES = ("max_w", "max_phi_dev", "l2_velocity")
#: the CVODE configurations on the py-pde path ('auto' takes the native engine on small grids:
#: benchmarks/native2d_speed.py compares the two)
CONFIGS = {
    "fast": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--engine", "pde"],
    "fast-gmres": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--jacobian", "krylov", "--engine", "pde"],
    "fast-upwind": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--advection", "upwind", "--engine", "pde"],
    "fast-amg": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--jacobian", "amg", "--engine", "pde"],
    "fast-order5": ["--method", "CVODE", "--rtol", "1e-5", "--atol", "1e-8", "--max-order", "5", "--engine", "pde"],
    "baseline": ["--method", "BDF", "--jacobian", "colored-fd", "--rtol", "1e-5", "--atol", "1e-8"],
    "reference": ["--method", "CVODE", "--rtol", "1e-8", "--atol", "1e-11", "--engine", "pde"],
    "reference-fast-only": ["--method", "CVODE", "--rtol", "1e-7", "--atol", "1e-10", "--engine", "pde"],  # cheaper, for 256^2
}
LABELS = {"fast": "CVODE, GMRES + x-Fourier, central", "fast-gmres": "CVODE, GMRES alone, central",
          "fast-upwind": "CVODE, GMRES + x-Fourier, upwind", "fast-amg": "CVODE, GMRES + AMG, central",
          "fast-order5": "CVODE, GMRES + x-Fourier, central, BDF orders <= 5 (amplifies short waves)",
          "baseline": "scipy BDF, colored sparse FD J"}
RICHARDSON = pathlib.Path("data") / "sim2d" / "richardson.json"


def cli_run(n: int, options, times=TIMES, timeout: float | None = None):
    """One CLI process of iCIDR bump2d on n^2 cells to t = 10 with `options`: (wall time,
    its rusage from wait4, the JSON it wrote); TimeoutError if it runs longer than `timeout`
    seconds (the process is then stopped)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "out.json"
        cmd = [sys.executable, "-m", "icidr_pde.cli", "run", "--scene", "bump2d", "--rheology", "icidr",
               "--Nx", str(n), "--Nz", str(n), "--t-end", "10", "--times", *times, "--no-progress",
               "--json", str(out), *options]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        stderr = []
        reader = threading.Thread(target=lambda: stderr.append(proc.stderr.read().decode()), daemon=True)
        reader.start()
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if timeout is not None and time.perf_counter() - start > timeout:
                proc.kill()
                os.wait4(proc.pid, 0)
                raise TimeoutError(f"{' '.join(cmd)} ran longer than {timeout:.0f} s")
            time.sleep(0.2)
        wall = time.perf_counter() - start
        reader.join()
        stderr = "".join(stderr)
        proc.stderr.close()
        if os.waitstatus_to_exitcode(status) != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{stderr}")
        return wall, usage, json.loads(out.read_text())


def whole_process(n: int, config: str, timeout: float | None = None) -> dict | None:
    """Run one CLI process; return its wall time, peak RSS and the JSON it wrote (None: it did
    not finish within `timeout` seconds and was stopped)."""
    try:
        wall, usage, result = cli_run(n, CONFIGS[config], timeout=timeout)
    except TimeoutError:
        return None
    return {"process_s": wall, "process_cpu_s": usage.ru_utime + usage.ru_stime, "max_rss_mb": usage.ru_maxrss / 1024,
            "solve_s": result["wall_s"],
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
    parser.add_argument("--sizes", type=int, nargs="*", default=[32, 64])
    parser.add_argument("--fast-only", type=int, nargs="*", default=[128, 256],
                        help="grids timed with the fast path only (the baseline takes > 10 min at 128^2)")
    parser.add_argument("--large", type=int, nargs="*", default=[],
                        help="grids timed with the default alone (and its reference at rtol 1e-7): 512^2 and above")
    parser.add_argument("--timeout", type=float, default=1200.0,
                        help="seconds after which a run is stopped (reported as not finished)")
    parser.add_argument("--no-large-reference", action="store_true",
                        help="no reference run on the --large grids (error then '–'; the grid error stays)")
    parser.add_argument("--configs", nargs="+", choices=tuple(LABELS),
                        help="time only these configurations (default: all of each grid's kind)")
    parser.add_argument("--json", default="data/benchmarks/sim2d_speed.json")
    args = parser.parse_args()
    rows = []
    for n in args.sizes + args.fast_only + args.large:
        if n in args.large:
            reference, configs = "reference-fast-only", ("fast",)
        elif n in args.fast_only:
            reference, configs = "reference-fast-only", ("fast", "fast-order5", "fast-gmres", "fast-upwind", "fast-amg")
        else:
            reference, configs = "reference", ("fast", "fast-order5", "fast-gmres", "fast-upwind", "fast-amg", "baseline")
        configs = tuple(c for c in configs if args.configs is None or c in args.configs)
        row = {"N": n, "reference_config": reference}
        for config in configs:  # the reference after them: the fast paths first where a grid may not finish
            row[config] = whole_process(n, config, timeout=args.timeout)
            if row[config] is None:
                print(f"{n}^2 {config}: not finished within {args.timeout:.0f} s", flush=True)
                row[config] = {"not_finished_within_s": args.timeout}
                continue
            print(f"{n}^2 {config}: {row[config]['process_s']:.1f} s process, {row[config]['solve_s']:.2f} s solve, "
                  f"{row[config]['max_rss_mb']:.0f} MB", flush=True)
        skip = n in args.large and args.no_large_reference
        ref = row["reference"] = None if skip else whole_process(n, reference, timeout=args.timeout)
        for config in configs:
            if "not_finished_within_s" in row[config]:
                continue
            row[config]["error"] = error(row[config], ref) if config != "fast-upwind" and ref else None
            row[config]["grid_error"] = grid_error(row[config])
            err, gerr = (row[config][k] for k in ("error", "grid_error"))
            print(f"{n}^2 {config}: error {'none (no reference)' if err is None else f'{err:.1e}'}, "
                  f"grid error {'none' if gerr is None else f'{gerr:.1e}'}", flush=True)
        rows.append(row)
    print("\niCIDR bump2d to t = 10 (error: largest relative error of max_w, max_phi_dev, l2_velocity at "
          "t = 0.5 ... 10 against CVODE rtol 1e-8 on the same grid)")
    print("| grid | method | steps | process [s] | process CPU [s] | solve [s] | peak RSS [MB] | error | grid error max_w | solve ratio |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in rows:
        for config, label in LABELS.items():
            if config not in row or row[config] is None:
                continue
            r = row[config]
            if "not_finished_within_s" in r:
                print(f"| {row['N']}² | {label} | – | > {r['not_finished_within_s']:.0f} | – | – | – | – | – | – |")
                continue
            fast = row.get("fast", {}).get("solve_s")
            ratio = f"{r['solve_s'] / fast:.1f}" if fast else "–"
            err = "–" if r["error"] is None else f"{r['error']:.1e}"
            gerr = "–" if r["grid_error"] is None else f"{r['grid_error']:.1%}"
            print(f"| {row['N']}² | {label} | {r['n_steps']} | {r['process_s']:.1f} | {r['process_cpu_s']:.1f} | {r['solve_s']:.2f} | {r['max_rss_mb']:.0f} | "
                  f"{err} | {gerr} | {ratio} |")
    write_json(args.json, {"rows": rows, "configs": CONFIGS, "times": TIMES,
                           "command": "nice -n 10 python benchmarks/sim2d_speed.py " + " ".join(sys.argv[1:])})


if __name__ == "__main__":
    main()
