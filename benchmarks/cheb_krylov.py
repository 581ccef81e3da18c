"""Chebyshev collocation beyond the dense LU: the native engine's linear solvers measured.

    nice -n 5 python benchmarks/cheb_krylov.py tstar [--N 101 201 401] [--rtols 1e-5 1e-7] [--json out.json]
    nice -n 5 python benchmarks/cheb_krylov.py speed [--repeats 3] [--json out.json]
    nice -n 5 python benchmarks/cheb_krylov.py large [--N 401 801] [--json out.json]
    nice -n 5 python benchmarks/cheb_krylov.py roofline [--N 201]

Linear solvers (``--solvers``, each ``NAME[:key=value,...]`` over
:data:`icidr_pde.cells.shear1d.native_cheb.KRYLOV`): ``dense`` (the default: CVODE's dense LU of
I - gamma J, LAPACK), ``band`` (SPGMR, J v by CVODE's difference quotients, preconditioned by
the band LU of I - gamma J_lo, J_lo the law's Jacobian with D replaced by low-order differences
on the CGL points) and ``lagged`` (SPGMR preconditioned by the dense LU of an earlier step).

* ``tstar``: t* of mu(I), scene shear (3.16), at each N, per solver, GMRES tolerance factor
  (``eps_lin``) and CVODE tolerance, in process (the round-off seed: the spread of t* between
  solvers must stay at the level of the dense path's own spread between tolerances); ``--rtols``
  the CVODE tolerances (atol = rtol / 1000), at N = 201 with the error against the converged t*.
* ``speed``: end_to_end.py's ``tstar-cheb`` (mu(I) N = 201 to t*, rtol 1e-7, atol 1e-10) and
  ``sine-cheb`` (iCIDR sine N = 201, t = 15, rtol 1e-5, atol 1e-8) and a t*(N) sweep, N = 21..201
  step 20, t_end = 20, at the standard preset's Chebyshev tolerances (rtol 1e-7, atol 1e-10; the
  baseline too), as whole
  processes, interleaved with end_to_end.py's scipy baseline (BDF, dense analytic Jacobian,
  numpy right-hand side) in the same run; in-process solve times beside them.
* ``large``: time, steps and peak memory (ru_maxrss of the child) at N = 401, 801.
* ``roofline``: each path's counts times the measured cost of each operation (a right-hand
  side and the dense J timed in C, best of 20; the low-order band J_lo, the band LU and solve,
  a dense LU and solve timed in CPU seconds), against the run's CPU time: what it is limited by.

A project run is one process ``python benchmarks/cheb_krylov.py --one SOLVER CASE N`` importing
``icidr_pde.native`` only (the run path of ``icidr-pde run`` for these cases, without the
command line's argument handling), OPENBLAS_NUM_THREADS=1 everywhere (as end_to_end.py).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from end_to_end import CASES, ROOT, TIMES  # noqa: E402
from provenance import write_json  # noqa: E402

SWEEP_N = tuple(range(21, 202, 20))


def standard_cheb() -> dict:
    """The standard preset's Chebyshev tolerances (icidr_pde.presets)."""
    from icidr_pde.presets import PRESETS, scheme_value

    return {key: scheme_value(PRESETS["standard"][key], "cheb") for key in ("rtol", "atol")}


#: the cases a project run can do: end_to_end.py's two Chebyshev ones and the t*(N) sweep
RUNS = {
    "tstar-cheb": dict(CASES["tstar-cheb"], rtol=1e-7, atol=1e-10),
    "sine-cheb": dict(CASES["sine-cheb"], rtol=1e-5, atol=1e-8),
    "tstar-std": dict(CASES["tstar-cheb"], **standard_cheb()),
    "sweep": dict(CASES["tstar-cheb"], t_end=20.0, **standard_cheb()),
}
REFERENCE = json.loads((ROOT / "data" / "reference" / "mui-shear-tstar-cheb.json").read_text())["t_star"]


def parse_solver(text: str) -> tuple[str, dict]:
    """'band:eps_lin=0.005' -> ('krylov', {'preconditioner': 'band', 'eps_lin': 0.005}); 'dense' -> ('dense', {})."""
    name, _, rest = text.partition(":")
    options = {k: float(v) for k, v in (kv.split("=") for kv in rest.split(",") if kv)}
    if name == "dense":
        return "dense", options
    return "krylov", {"preconditioner": {"band": "band", "lagged": "dense"}[name], **options}


def one(solver: str, case: str, N: int, rtol=None, atol=None) -> dict:
    """One project run (in this process): t*, max|w| at the snapshot times, counts, times."""
    from icidr_pde.api import run
    from icidr_pde.cells.shear1d import native_cheb as cheb

    linear_solver, options = parse_solver(solver)
    cheb.LINEAR_SOLVER = linear_solver
    krylov = dict(cheb.KRYLOV)
    cheb.KRYLOV.update(options)
    counts = {}
    original = cheb.ChebProblem.counts

    def keep(problem):
        counts.update(original(problem))
        return counts

    cheb.ChebProblem.counts = keep
    spec = RUNS[case]
    try:
        Ns = SWEEP_N if case == "sweep" else [N]
        rows = []
        for n in Ns:
            counts.clear()
            times = [0.0] + [t for t in TIMES if t <= spec["t_end"]]
            r = run(spec["rheology"], spec["scene"], n, spec["t_end"], times=times, discretization="cheb",
                    method="CVODE", rtol=rtol or spec["rtol"], atol=atol or spec["atol"], engine="native")
            rows.append(dict(N=n, t_star=r.t_star, wall_s=r.wall_s, cpu_s=r.cpu_s, compile_s=r.compile_s,
                             reason=r.reason, mass_drift=r.mass_drift,
                             max_w={f"{t:g}": float(abs(r.w[k]).max()) for k, t in enumerate(r.times)},
                             **dict(counts)))
    finally:
        cheb.KRYLOV.clear()
        cheb.KRYLOV.update(krylov)
        cheb.ChebProblem.counts = original
    return dict(solver=solver, case=case, runs=rows, solve_s=sum(r["wall_s"] for r in rows),
                peak_mib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)


def environment() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")


def process(args: list[str]) -> tuple[float, dict]:
    """Wall time of a child process and the JSON it printed on its last line."""
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, *args], capture_output=True, text=True, env=environment(), cwd=ROOT)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall, json.loads(proc.stdout.strip().splitlines()[-1])


def project(solver: str, case: str, N: int = 201) -> dict:
    wall, data = process([__file__, "--one", solver, case, str(N)])
    return dict(data, wall_s=wall)


def baseline(case: str) -> dict:
    """end_to_end.py's scipy script as one process (the sweep: its t* at every N in one process)."""
    if case != "sweep":
        with_json = ROOT / f".baseline-{os.getpid()}.json"
        try:
            start = time.perf_counter()
            subprocess.run([sys.executable, str(ROOT / "benchmarks" / "end_to_end.py"), "--baseline",
                            {"tstar-std": "tstar-cheb"}.get(case, case), "--json", str(with_json)], check=True,
                           env=environment(), cwd=ROOT, capture_output=True)
            wall = time.perf_counter() - start
            return dict(json.loads(with_json.read_text()), wall_s=wall)
        finally:
            with_json.unlink(missing_ok=True)
    wall, data = process([__file__, "--baseline-sweep"])
    return dict(data, wall_s=wall)


def baseline_sweep() -> dict:
    """end_to_end.baseline_tstar at every N of the sweep, t_end = 20, the project's tolerances."""
    import end_to_end

    rows = []
    for N in SWEEP_N:
        end_to_end.CASES["tstar-cheb"].update(N=N, t_end=20.0, baseline=standard_cheb())
        rows.append(dict(N=N, **{k: v for k, v in end_to_end.baseline_tstar("tstar-cheb").items() if k != "max_w"}))
    return dict(runs=rows, solve_s=sum(r["solve_s"] for r in rows))


# --------------------------------------------------------------------------------------------
def tstar_table(Ns, solvers, tolerances) -> list[dict]:
    rows = []
    for N in Ns:
        for rtol, atol in tolerances:
            for solver in solvers:
                r = one(solver, "tstar-cheb", N, rtol=rtol, atol=atol)["runs"][0]
                rows.append(dict(r, solver=solver, rtol=rtol, atol=atol))
                error = f"  error {abs(r['t_star'] - REFERENCE) / REFERENCE:.2e}" if N == 201 and r['t_star'] else ""
                print(f"N {N:4d}  rtol {rtol:g} atol {atol:g}  {solver:28s} t* {r['t_star']!r:22s}{error}"
                      f"  solve {r['wall_s']:6.2f} s  steps {r['steps']:5d}  lu {r['lu']:4d}  jac {r['jac']:3d}"
                      f"  krylov {r.get('krylov_iterations', 0):5d}  newton {r['newton_iterations']:5d}", flush=True)
    return rows


def speed(solvers, repeats: int) -> dict:
    out = {}
    for case in ("tstar-cheb", "sine-cheb", "sweep"):
        runs = {name: [] for name in ("baseline", *solvers)}
        for _ in range(repeats):  # interleaved
            runs["baseline"].append(baseline(case))
            for solver in solvers:
                runs[solver].append(project(solver, case))
        out[case] = {}
        for name, rs in runs.items():
            wall = statistics.median(r["wall_s"] for r in rs)
            solve = statistics.median(r["solve_s"] for r in rs)
            t_star = rs[0].get("t_star") if case != "sweep" else None
            if t_star is None and case == "tstar-cheb":
                t_star = rs[0]["runs"][0]["t_star"]
            out[case][name] = dict(wall_s=wall, solve_s=solve, walls=[r["wall_s"] for r in rs],
                                   solves=[r["solve_s"] for r in rs], t_star=t_star,
                                   sweep=[(r["N"], r["t_star"]) for r in rs[0].get("runs", [])] if case == "sweep"
                                   else None, last=rs[-1])
        base = out[case]["baseline"]
        for name, row in out[case].items():
            ratio = f"  x{base['wall_s'] / row['wall_s']:.1f} whole, x{base['solve_s'] / row['solve_s']:.1f} in process"
            print(f"{case:10s} {name:28s} whole {row['wall_s']:7.2f} s  solve {row['solve_s']:7.2f} s"
                  f"{ratio if name != 'baseline' else ''}  t* {row['t_star']}", flush=True)
    return out


def large(Ns, solvers) -> list[dict]:
    rows = []
    for N in Ns:
        for solver in solvers:
            start = time.perf_counter()
            proc = subprocess.Popen([sys.executable, __file__, "--one", solver, "tstar-std", str(N)],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment(),
                                    cwd=ROOT)
            _, status, usage = os.wait4(proc.pid, 0)
            wall = time.perf_counter() - start
            out = proc.stdout.read()
            if status != 0:
                print(f"N {N} {solver}: failed ({status}) {proc.stderr.read()[-500:]}", flush=True)
                continue
            data = json.loads(out.strip().splitlines()[-1])
            r = data["runs"][0]
            rows.append(dict(r, solver=solver, whole_s=wall, peak_mib=usage.ru_maxrss / 1024))
            print(f"N {N:4d} {solver:28s} whole {wall:7.2f} s  solve {r['wall_s']:7.2f} s  peak {usage.ru_maxrss / 1024:7.0f}"
                  f" MiB  t* {r['t_star']!r}  steps {r['steps']}  lu {r['lu']}  krylov {r.get('krylov_iterations', 0)}",
                  flush=True)
    return rows


def best(call, repeats=20) -> float:
    """Best CPU seconds of `call` (one BLAS thread: on a loaded machine wall time counts the waits)."""
    times = []
    for _ in range(repeats):
        start = time.process_time()
        call()
        times.append(time.process_time() - start)
    return min(times)


def roofline(N: int) -> dict:
    """Each operation's cost at the initial state times the Krylov run's counts, against its solve."""
    import numpy as np
    from scipy.linalg import lu_factor, lu_solve
    from scipy.linalg.lapack import dgbtrf, dgbtrs

    from icidr_pde.native_case import ChebCase

    case = ChebCase("mui", "shear", N)
    problem = case.problem(linear_solver="krylov", krylov={"preconditioner": "band"})
    y = case.y0
    t_rhs, t_jac = problem.kernel_times(y, repeats=20)
    t_jlo = best(lambda: problem.jacobian_low_order(y), 5)
    n3 = 3 * N
    P = np.eye(n3) - 1e-6 * problem.jacobian_dense(y)
    t_lu = best(lambda: lu_factor(P), 5)
    factored = lu_factor(P)
    t_lu_solve = best(lambda: lu_solve(factored, y), 50)
    band = np.zeros((16, n3))
    t_band = best(lambda: dgbtrf(band, 5, 5), 50)
    lu, piv, _ = dgbtrf(np.vstack([np.zeros((5, n3)), np.eye(1, n3).repeat(11, 0)]), 5, 5)
    t_band_solve = best(lambda: dgbtrs(lu, 5, 5, y, piv), 200)
    costs = dict(rhs=t_rhs, jacobian_dense=t_jac, jacobian_low_order=t_jlo, dense_lu=t_lu, dense_solve=t_lu_solve,
                 band_lu=t_band, band_solve=t_band_solve)
    out = dict(N=N, costs=costs)
    for solver in ("dense", "band"):
        r = one(solver, "tstar-cheb", N)["runs"][0]
        if solver == "dense":
            parts = dict(rhs=r["rhs"] * t_rhs, jacobian=r["jac"] * t_jac, lu=r["lu"] * t_lu,
                         solves=r["newton_iterations"] * t_lu_solve)
        else:
            parts = dict(rhs=(r["rhs"] - r["jv_rhs"]) * t_rhs, jv=r["jv_rhs"] * t_rhs,
                         jacobian_low_order=r["jac"] * t_jlo, band_lu=r["lu"] * t_band,
                         band_solves=r["preconditioner_solves"] * t_band_solve)
        limit = sum(parts.values())
        out[solver] = dict(counts=r, parts=parts, limit_s=limit, solve_s=r["wall_s"], solve_cpu_s=r["cpu_s"])
        print(f"N {N} {solver}: solve {r['wall_s']:.3f} s (CPU {r['cpu_s']:.3f} s), limit {limit:.3f} s "
              f"(measured CPU/limit {r['cpu_s'] / limit:.2f}); "
              + ", ".join(f"{k} {v:.3f} s ({100 * v / limit:.0f} %)" for k, v in parts.items()), flush=True)
    print("costs: " + ", ".join(f"{k} {1e3 * v:.3f} ms" for k, v in costs.items()))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", nargs="?", choices=("tstar", "speed", "large", "roofline"))
    parser.add_argument("--one", nargs=3, metavar=("SOLVER", "CASE", "N"), help="one project run (internal)")
    parser.add_argument("--baseline-sweep", action="store_true", help="the baseline's sweep (internal)")
    parser.add_argument("--N", type=int, nargs="+")
    parser.add_argument("--solvers", nargs="+")
    parser.add_argument("--rtols", type=float, nargs="+", help="tstar: CVODE rtols (atol = rtol / 1000)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json")
    args = parser.parse_args(argv)
    os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    if args.one:
        print(json.dumps(one(args.one[0], args.one[1], int(args.one[2]))))
        return 0
    if args.baseline_sweep:
        print(json.dumps(baseline_sweep()))
        return 0
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")
    if args.what == "tstar":
        data = tstar_table(args.N or (101, 201, 401),
                           args.solvers or ("dense", "band", "band:eps_lin=0.005", "band:eps_lin=0.0005", "lagged"),
                           [(rtol, rtol / 1000) for rtol in args.rtols or (1e-5, 1e-7)])
    elif args.what == "speed":
        data = speed(args.solvers or ("dense", "band"), args.repeats)
    elif args.what == "large":
        data = large(args.N or (401, 801), args.solvers or ("dense", "band"))
    elif args.what == "roofline":
        data = roofline((args.N or [201])[0])
    else:
        parser.error("say what to measure")
    print(f"load {os.getloadavg()[0]:.1f}; reference t* (N = 201, BDF rtol 1e-10) {REFERENCE!r}")
    if args.json:
        write_json(args.json, dict(load=os.getloadavg(), data=data), default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
