"""Fig 4(b)'s t*(N) sweep, whole processes, against a careful scipy script, with the t* accuracy beside.

    nice -n 10 python benchmarks/tstar_sweep.py [--repeats 3] [--json data/benchmarks/tstar_sweep.json]

Three measurements, each a whole process (start, imports, library loads, worker pool, runs, the
JSON and plot written) timed from outside, interleaved over ``--repeats`` rounds after one
unreported warm-up of the project (the kernel cache filled: "warm"):

* ``full``: ``icidr-pde tstar --rheology mui --scene shear --discretization fd cheb --N 21:201:2
  --plot tstar.png`` (182 runs, its default ``--accuracy stated``, its default 2 worker processes);
* ``cheb-sweep``: ``icidr-pde tstar --discretization cheb --N 21:201:20`` against the baseline's
  loop over the same N in one process;
* ``cheb-201``: ``icidr-pde tstar --discretization cheb --N 201`` against the baseline at N = 201.

**Baseline**: end_to_end.py's plain numpy + scipy script (:func:`end_to_end.baseline_tstar`: the
Chebyshev collocation written out, the dense analytic Jacobian, scipy's BDF stepped by hand to the
failure), at the paper's tolerances (rtol 1e-6, atol 1e-9; ``--baseline-rtol`` another), t_end = 20, run as
``python benchmarks/tstar_sweep.py --baseline N ...`` with OPENBLAS_NUM_THREADS=1 (one thread:
end_to_end.py's docstring says why).

**Accuracy** (beside every timing): each Chebyshev t* against the converged t* of
data/tstar/tstar_accuracy.json (benchmarks/tstar_accuracy.py), relative, the largest over the N
run, and whether every N agrees on failing or not; each finite-volume t* against the median of
that file's tight runs, with the number of N outside the accuracy stated there.

Timings on a shared machine are upper bounds: the provenance records the load at start and end,
and the load is printed beside each round. Beside each wall time the CPU time of the process and
of its workers (user + system): on a loaded machine a process waits for cores, and its CPU time
is the better measure of what it costs (on 2 idle cores the full command takes about its CPU time
over 2 plus what does not run in parallel).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from provenance import ROOT, write_json  # noqa: E402

ACCURACY_FILE = ROOT / "data" / "tstar" / "tstar_accuracy.json"
FULL = ["tstar", "--rheology", "mui", "--scene", "shear", "--discretization", "fd", "cheb", "--N", "21:201:2"]
SWEEP_N = list(range(21, 202, 20))
#: the baseline's tolerances: by default the paper's (scipy's BDF as the paper's ode15s);
#: ``--baseline-rtol`` another (atol = rtol / 1000)
BASELINE = dict(rtol=1e-6, atol=1e-9)
T_END = 20.0


def baseline(Ns) -> dict:
    """The scipy script at every N, in this process: {N: t* or None}, solve seconds."""
    import end_to_end

    t_star, solve = {}, 0.0
    for N in Ns:
        end_to_end.CASES["tstar-cheb"].update(N=N, t_end=T_END, baseline=BASELINE)
        r = end_to_end.baseline_tstar("tstar-cheb")
        t_star[str(N)] = None if r["t_star"] >= T_END else r["t_star"]  # it returns the last good time
        solve += r["solve_s"]
    return dict(t_star=t_star, solve_s=solve)


def environment(blas_one: bool) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    if blas_one:
        env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return env


#: CPU seconds (user + system) of the last process :func:`whole` ran, its worker processes included:
#: on a loaded machine the wall time waits for cores, the CPU time much less
LAST_CPU = [0.0]


def whole(args: list[str], env: dict) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(args, env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    LAST_CPU[0] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall


def project(argv: list[str], out: Path) -> tuple[float, dict]:
    """Whole-process wall time of ``icidr-pde ARGV --json OUT --no-progress`` and its t* by discretization."""
    wall = whole([sys.executable, "-m", "icidr_pde.cli", *argv, "--json", str(out), "--no-progress"],
                 environment(False))
    document = json.loads(out.read_text())
    return wall, {d: e["t_star"] for d, e in document["discretizations"].items()}


def scripted(Ns) -> tuple[float, dict]:
    out = tempfile.NamedTemporaryFile(suffix=".json", delete=False)
    out.close()
    try:
        wall = whole([sys.executable, __file__, "--baseline", *map(str, Ns), "--out", out.name,
                      "--baseline-rtol", repr(BASELINE["rtol"])], environment(True))
        return wall, json.loads(Path(out.name).read_text())["t_star"]
    finally:
        os.unlink(out.name)


#: the parts of the full command besides its runs, each a whole process: start and the command's
#: imports; the same plus a pool of the 2 workers the sweep starts (each importing what a case
#: needs); the plot of a saved sweep (start, imports, matplotlib, drawing)
PARTS = {
    "start and imports": ["-c", "import icidr_pde.cli.tstar"],
    "start, imports and worker pool": ["-c", "import importlib, multiprocessing, time, icidr_pde.cli.tstar\n"
                                             "from icidr_pde.studies import parallel\n"
                                             "if __name__ == '__main__':\n"
                                             "    parallel.single_thread_environment()\n"
                                             "    with multiprocessing.get_context('spawn').Pool(\n"
                                             "            2, importlib.import_module, ('icidr_pde.studies.failure_time',)) as pool:\n"
                                             "        pool.map(time.sleep, [0.05] * 2, chunksize=1)"],
    "plot of the saved sweep": ["-m", "icidr_pde.cli", "tstar", "--load", "SWEEP", "--plot", "PLOT"],
}


def accuracy(curves: dict, truth: dict) -> dict:
    """The t* accuracy of `curves` ({discretization: {N: t*}}) against tstar_accuracy.json."""
    out = {}
    for disc, curve in curves.items():
        ref = truth["cheb"]["converged"] if disc == "cheb" else truth["fd"]["reference"]
        bound = ({n: truth["cheb"]["accuracy"] for n in curve} if disc == "cheb" else truth["fd"]["accuracy"])
        same_fate = all((t is None) == (ref[n] is None) for n, t in curve.items())
        errors = {n: abs(t - ref[n]) / ref[n] for n, t in curve.items() if t is not None and ref[n] is not None}
        outside = sorted(int(n) for n, e in errors.items() if bound[n] is not None and e > bound[n])
        claimed_from = truth["fd"]["checked_from"] if disc == "fd" else 0  # the N the accuracy is stated for
        out[disc] = dict(max_error=max(errors.values(), default=0.0), same_fate=same_fate, outside=outside,
                         outside_where_stated=[n for n in outside if n >= claimed_from])
    return out


def shown(acc: dict) -> str:
    return "; ".join(f"{d} t* max error {a['max_error']:.1e}, fails where the converged fails: {a['same_fate']}, "
                     f"outside the stated accuracy where it is stated at N {a['outside_where_stated'] or 'none'} "
                     f"(anywhere: {a['outside'] or 'none'})" for d, a in acc.items())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--json", default=str(ROOT / "data" / "benchmarks" / "tstar_sweep.json"))
    p.add_argument("--baseline", type=int, nargs="+", help=argparse.SUPPRESS)  # the child: the scipy script
    p.add_argument("--out", help=argparse.SUPPRESS)
    p.add_argument("--baseline-rtol", type=float, default=BASELINE["rtol"],
                   help="the baseline's rtol (atol = rtol / 1000; default: the paper's 1e-6)")
    args = p.parse_args(argv)
    BASELINE.update(rtol=args.baseline_rtol, atol=args.baseline_rtol * 1e-3)
    if args.baseline:
        write_json(args.out, baseline(args.baseline), stamp=False)  # a child's hand-over, not a measurement
        return 0
    truth = json.loads(ACCURACY_FILE.read_text())
    cases = {"full": dict(project=FULL + ["--plot", "PLOT"], baseline=None),
             "cheb-sweep": dict(project=["tstar", "--discretization", "cheb", "--N", "21:201:20"], baseline=SWEEP_N),
             "cheb-201": dict(project=["tstar", "--discretization", "cheb", "--N", "201"], baseline=[201])}
    rounds = {name: dict(project=[], baseline=[], load=[], project_cpu=[], baseline_cpu=[]) for name in cases}
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        plot = str(folder / "tstar.png")
        project([a if a != "PLOT" else plot for a in cases["full"]["project"]], folder / "full.json")  # warm-up
        for r in range(args.repeats):
            for name, case in cases.items():
                load = os.getloadavg()[0]
                wall, curves = project([a if a != "PLOT" else plot for a in case["project"]], folder / f"{name}.json")
                rounds[name]["project"].append(wall)
                rounds[name]["project_cpu"].append(LAST_CPU[0])
                rounds[name]["load"].append(load)
                results.setdefault(name, {})["project"] = curves
                line = f"round {r + 1} {name:10s} load {load:5.2f}  project {wall:6.2f} s (CPU {LAST_CPU[0]:6.2f} s)"
                if case["baseline"] is not None:
                    b_wall, b_curve = scripted(case["baseline"])
                    rounds[name]["baseline"].append(b_wall)
                    rounds[name]["baseline_cpu"].append(LAST_CPU[0])
                    results[name]["baseline"] = {"cheb": b_curve}
                    line += (f"  baseline {b_wall:6.2f} s (CPU {LAST_CPU[0]:6.2f} s)  x{b_wall / wall:.1f} wall, "
                             f"x{LAST_CPU[0] / rounds[name]['project_cpu'][-1]:.1f} CPU")
                print(line, flush=True)
        parts, parts_cpu = {}, {}
        for part, args_ in PARTS.items():
            argv_ = [{"SWEEP": str(folder / "full.json"), "PLOT": plot}.get(a, a) for a in args_]
            walls, cpus = [], []
            for _ in range(args.repeats):
                walls.append(whole([sys.executable, *argv_], environment(False)))
                cpus.append(LAST_CPU[0])
            parts[part] = statistics.median(walls)
            parts_cpu[part] = statistics.median(cpus)
            print(f"{part:32s} {parts[part]:6.2f} s, CPU {parts_cpu[part]:6.2f} s", flush=True)
    summary = {}
    for name, case in cases.items():
        row = dict(command="icidr-pde " + " ".join(a if a != "PLOT" else "tstar.png" for a in case["project"]),
                   project_s=statistics.median(rounds[name]["project"]), project_rounds=rounds[name]["project"],
                   project_cpu_s=statistics.median(rounds[name]["project_cpu"]),
                   project_cpu_rounds=rounds[name]["project_cpu"],
                   load_1min=rounds[name]["load"], project_accuracy=accuracy(results[name]["project"], truth),
                   project_t_star=results[name]["project"])
        if case["baseline"] is not None:
            row.update(baseline="end_to_end.baseline_tstar (scipy BDF, dense analytic Jacobian), "
                                f"rtol {BASELINE['rtol']:g}, atol {BASELINE['atol']:g}, N = {case['baseline']}",
                       baseline_s=statistics.median(rounds[name]["baseline"]), baseline_rounds=rounds[name]["baseline"],
                       baseline_cpu_s=statistics.median(rounds[name]["baseline_cpu"]),
                       baseline_cpu_rounds=rounds[name]["baseline_cpu"],
                       baseline_accuracy=accuracy(results[name]["baseline"], truth),
                       baseline_t_star=results[name]["baseline"]["cheb"])
            row["speed_up"] = row["baseline_s"] / row["project_s"]
            row["speed_up_cpu"] = row["baseline_cpu_s"] / row["project_cpu_s"]
        summary[name] = row
        print(f"{name:10s} project {row['project_s']:6.2f} s, CPU {row['project_cpu_s']:6.2f} s (median of "
              f"{args.repeats}; {shown(row['project_accuracy'])})")
        if case["baseline"] is not None:
            print(f"{'':10s} baseline {row['baseline_s']:6.2f} s, CPU {row['baseline_cpu_s']:6.2f} s "
                  f"({shown(row['baseline_accuracy'])}); x{row['speed_up']:.1f} wall, x{row['speed_up_cpu']:.1f} CPU")
    for times, key in ((parts, "project_s"), (parts_cpu, "project_cpu_s")):
        full = summary["full"][key]
        times["the runs (the rest)"] = full - times["start, imports and worker pool"] - (
            times["plot of the saved sweep"] - times["start and imports"])
        print(f"full command {full:.2f} s ({key}): " + ", ".join(f"{k} {v:.2f} s" for k, v in times.items()))
    write_json(args.json, dict(t_end=T_END, accuracy_file=str(ACCURACY_FILE.relative_to(ROOT)), cases=summary,
                               parts_of_the_full_command=parts, parts_of_the_full_command_cpu=parts_cpu))
    print(f"written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
