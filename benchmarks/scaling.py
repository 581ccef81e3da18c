"""Scaling: time and peak memory of the reference cases against N, with fitted exponents.

    nice -n 10 python benchmarks/scaling.py [--cases shear-fd sine-fd tstar-cheb sine-cheb]
        [--fd-N 51 101 201 401 801 1601 3201] [--cheb-N 51 101 201 401]
        [--fit-fd-from 401] [--fit-cheb-from 101] [--repeats 1] [--json data/benchmarks/scaling.json]

The cases are end_to_end.py's (:data:`end_to_end.CASES`: rheology, scene, discretization,
t_end, reference), imported from there; only N varies. Every run is one whole process,
``python -m icidr_pde.cli run --rheology R --scene S --discretization D --N N --t-end T
--times 0 3 5 ... --json out.json --no-progress``, one at a time, with the CLI's defaults for
everything else (preset ``standard``: CVODE, rtol 1e-5, atol 1e-8, the analytic Jacobian):
what a user gets who only changes N. OPENBLAS_NUM_THREADS=1 in every process; run the
benchmark itself under ``nice -n 10`` on a shared machine. The kernels are loaded from the
user's cache (one untimed run per law and discretization fills it first; a timed run that
compiled is flagged).

Per run: the whole-process wall time; the in-process solve (``wall_s``) and set-up
(``compile_s``) of the JSON; CVODE's steps and right-hand-side calls; the peak resident
memory of the process (``ru_maxrss`` from ``os.wait4`` of that child alone), also above the
floor of a process that only imports the API (``from icidr_pde.api import run`` plus numba);
and beside them the accuracy of end_to_end.py (:func:`end_to_end.accuracy`: the max over
t in {3, 5, 10, 15, 20} <= t_end of the relative error of max|w| against the converged
reference of data/reference, finite volumes N = 3201 at CVODE rtol 1e-10, so at N = 3201 it
measures the time error only). For the t* case there is no converged value to compare to at
other N (mu(I),Phi(I) is ill-posed: t* falls with N) and the reference is at N = 201 only:
its error is given there, the t* of every N is printed.

Fitted exponents: least squares of log(time) on log(N) over N >= --fit-fd-from (finite
volumes) or --fit-cheb-from (Chebyshev), the range where the fixed costs no longer dominate;
for the solve, the whole process above its N-independent part (the smallest N's whole
process minus its solve), the right-hand-side calls (CVODE's JSON gives no step count),
the solve time per right-hand-side call (the cost of a step's work: RHS, Jacobian, LU) and
the peak memory above the smallest N's. The load average of the machine
is recorded before and after every run.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import end_to_end  # noqa: E402  (the reference cases and their accuracy)
from end_to_end import CASES, ROOT, TIMES  # noqa: E402
from provenance import write_json  # noqa: E402

FD_N = (51, 101, 201, 401, 801, 1601, 3201)
CHEB_N = (51, 101, 201, 401)
FLOOR = "import numba; from icidr_pde.api import run"


def environment() -> dict:
    return dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")


def measured(args: list[str], env: dict, cwd: Path, ok=(0,)) -> dict:
    """Run `args` as a child; its wall time, its own peak RSS (MiB), CPU (user, system) and minor page
    faults, exit status and stderr."""
    load = os.getloadavg()[0]
    with tempfile.TemporaryFile("w+") as err:
        start = time.perf_counter()
        proc = subprocess.Popen(args, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=err, text=True)
        # wait4: this child's rusage alone (RUSAGE_CHILDREN would be the maximum over all children)
        _, wait_status, rusage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(wait_status)
        err.seek(0)
        stderr = err.read()
    if proc.returncode not in ok:
        raise RuntimeError(f"{' '.join(map(str, args))} exited {proc.returncode}:\n{stderr[-2000:]}")
    return dict(wall_s=wall, peak_mib=rusage.ru_maxrss / 1024, user_s=rusage.ru_utime, system_s=rusage.ru_stime,
                minor_faults=rusage.ru_minflt, stderr=stderr, status=proc.returncode,
                load=[load, os.getloadavg()[0]])  # ru_maxrss is in KiB on Linux


def case_at(case: str, N: int) -> str:
    """end_to_end's case `case` at grid size N, registered under its own key (same definition)."""
    key = f"{case}@N={N}"
    CASES[key] = dict(CASES[case], N=N)
    return key


EXTRA: list[str] = []  # --cli-options


def cli_args(case: str, N: int, out: Path) -> list[str]:
    spec = CASES[case]
    times = ["0"] + [f"{t:g}" for t in TIMES if t <= spec["t_end"]]
    return [sys.executable, "-m", "icidr_pde.cli", "run", "--rheology", spec["rheology"], "--scene", spec["scene"],
            "--discretization", spec["disc"], "--N", str(N), "--t-end", f"{spec['t_end']:g}", "--times", *times,
            "--json", str(out), "--no-progress", *EXTRA]


def one_run(case: str, N: int, env: dict, workdir: Path) -> dict:
    out = workdir / f"{case}-{N}.json"
    tstar = CASES[case]["ref"].startswith("mui-shear-tstar")
    row = measured(cli_args(case, N, out), env, workdir, ok=(0, 3) if tstar else (0,))
    data = json.loads(out.read_text())
    t_star = data["t_star"] if data["blew_up"] else None
    if tstar and N != CASES[case]["N"]:
        error = None  # no converged t* at this N
    else:
        error = end_to_end.accuracy(case_at(case, N), data["max_w"], t_star)
    return dict(case=case, N=N, wall_s=row["wall_s"], solve_s=data["wall_s"], setup_s=data["compile_s"],
                n_steps=data.get("n_steps"), n_rhs=data.get("n_rhs"), n_jac=data.get("n_jac"),
                peak_mib=row["peak_mib"], error=error, t_star=t_star, blew_up=data["blew_up"],
                compiled="compiling kernels" in row["stderr"], load=row["load"])


def fit(N, values, from_N) -> dict | None:
    """Exponent b of values ~ a N^b, least squares on log-log over N >= from_N."""
    pts = [(n, v) for n, v in zip(N, values) if n >= from_N and v is not None and v > 0]
    if len(pts) < 2:
        return None
    x, y = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
    b, a = np.polyfit(x, y, 1)
    return dict(exponent=float(b), range=[pts[0][0], pts[-1][0]], points=len(pts))


def summarise(rows: list[dict], fit_from: dict) -> dict:
    """Medians per (case, N) over repeats, and the fitted exponents per case."""
    out = {}
    for case in dict.fromkeys(r["case"] for r in rows):
        mine = [r for r in rows if r["case"] == case]
        table = []
        for N in sorted({r["N"] for r in mine}):
            runs = [r for r in mine if r["N"] == N]
            entry = {k: (statistics.median(r[k] for r in runs) if isinstance(runs[0][k], float) else runs[0][k])
                     for k in runs[0] if k != "load"}
            entry["wall_range"] = [min(r["wall_s"] for r in runs), max(r["wall_s"] for r in runs)]
            entry["solve_range"] = [min(r["solve_s"] for r in runs), max(r["solve_s"] for r in runs)]
            entry["compiled"] = any(r["compiled"] for r in runs)
            entry["repeats"] = len(runs)
            table.append(entry)
        for prev, e in zip(table, table[1:]):  # slope between neighbouring N: where the fit's range starts
            e["local_exponent"] = float(np.log(e["solve_s"] / prev["solve_s"]) / np.log(e["N"] / prev["N"]))
        Ns = [e["N"] for e in table]
        fixed = table[0]["wall_s"] - table[0]["solve_s"]  # the smallest N's start-up
        start = fit_from[CASES[case]["disc"]]
        fits = {
            "solve_s": fit(Ns, [e["solve_s"] for e in table], start),
            "wall_above_start_s": fit(Ns, [e["wall_s"] - fixed for e in table], start),
            "n_rhs": fit(Ns, [e["n_rhs"] for e in table], start),
            "solve_per_rhs_s": fit(Ns, [e["solve_s"] / e["n_rhs"] if e["n_rhs"] else None for e in table], start),
            "peak_growth_mib": fit(Ns, [e["peak_mib"] - table[0]["peak_mib"] for e in table], start),
        }
        out[case] = dict(table=table, fits=fits, start_s=fixed)
    return out


def measure(cases, fd_N, cheb_N, repeats: int) -> tuple[list[dict], dict]:
    with tempfile.TemporaryDirectory(prefix="icidr_scaling_") as folder:
        return _measure(cases, fd_N, cheb_N, repeats, environment(), Path(folder))


def _measure(cases, fd_N, cheb_N, repeats: int, env: dict, workdir: Path) -> tuple[list[dict], dict]:
    floor = measured([sys.executable, "-c", FLOOR], env, workdir)
    for case in cases:  # fill the kernel cache of each law and discretization (not timed)
        one_run(case, 51, env, workdir)
    rows = []
    for _ in range(repeats):
        for case in cases:
            for N in (fd_N if CASES[case]["disc"] == "fd" else cheb_N):
                row = one_run(case, N, env, workdir)
                row["peak_above_floor_mib"] = row["peak_mib"] - floor["peak_mib"]
                rows.append(row)
                print(f"  {case:10s} N = {N:5d}: {row['wall_s']:7.2f} s whole, {row['solve_s']:7.3f} s solve, "
                      f"{row['peak_mib']:6.0f} MiB, error {fmt_error(row['error'])}, load {row['load'][0]:.1f}",
                      file=sys.stderr, flush=True)
    return rows, dict(floor_peak_mib=floor["peak_mib"], floor_wall_s=floor["wall_s"])


def fmt_error(error) -> str:
    return "-" if error is None else f"{error:.1e}"


def fmt_fit(f) -> str:
    return "-" if f is None else f"N^{f['exponent']:.2f} (N = {f['range'][0]}-{f['range'][1]})"


def report(data: dict) -> str:
    lines = ["whole processes, one at a time, CLI defaults (standard: CVODE rtol 1e-5, atol 1e-8)"
             + (f" with {data['cli_options']}" if data.get("cli_options") else "") + ", "
             f"OPENBLAS_NUM_THREADS=1; median of {data['repeats']}; load average "
             f"{data['load'][0]:.1f}-{data['load'][1]:.1f} during the runs",
             f"floor: `python -c \"{FLOOR}\"` {data['floor_wall_s']:.2f} s, peak {data['floor_peak_mib']:.0f} MiB"]
    for case, res in data["cases"].items():
        spec = CASES[case]
        lines += ["", f"### {case}: {spec['rheology']}, scene {spec['scene']}, {spec['disc']}, t_end {spec['t_end']:g}"
                  + (" (runs to t*)" if spec["ref"].startswith("mui-shear-tstar") else ""), "",
                  "| N | whole process | solve [range] | local exponent | set-up | RHS calls | Jacobians | solve / RHS call | peak RSS (above floor) | error |"
                  + (" t* |" if spec["ref"].startswith("mui-shear-tstar") else ""),
                  "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
                  + (" --- |" if spec["ref"].startswith("mui-shear-tstar") else "")]
        for e in res["table"]:
            per_call = f"{1e3 * e['solve_s'] / e['n_rhs']:.3f} ms" if e["n_rhs"] else "-"
            slope = f"{e['local_exponent']:.2f}" if "local_exponent" in e else "-"
            spread = (f" [{e['solve_range'][0]:.3g}-{e['solve_range'][1]:.3g}]" if e["repeats"] > 1 else "")
            line = (f"| {e['N']} | {e['wall_s']:.2f} s | {e['solve_s']:.3f} s{spread} | {slope} | {e['setup_s']:.2f} s | {e['n_rhs']} | "
                    f"{e['n_jac']} | {per_call} | {e['peak_mib']:.0f} MiB ({e['peak_above_floor_mib']:+.0f}) | "
                    f"{fmt_error(e['error'])} |")
            if spec["ref"].startswith("mui-shear-tstar"):
                line += f" {e['t_star']:.6g} |" if e["t_star"] is not None else " none |"
            lines.append(line + (" (compiled)" if e["compiled"] else ""))
        f = res["fits"]
        lines.append("")
        lines.append(f"fits (least squares, log-log): solve {fmt_fit(f['solve_s'])}; whole process above its "
                     f"{res['start_s']:.2f} s start {fmt_fit(f['wall_above_start_s'])}; RHS calls {fmt_fit(f['n_rhs'])}; "
                     f"solve per RHS call {fmt_fit(f['solve_per_rhs_s'])}; peak memory above the smallest N's "
                     f"{fmt_fit(f['peak_growth_mib'])}")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", nargs="+", choices=[c for c in CASES if "@" not in c], default=list(CASES))
    parser.add_argument("--fd-N", type=int, nargs="+", default=list(FD_N))
    parser.add_argument("--cheb-N", type=int, nargs="+", default=list(CHEB_N))
    parser.add_argument("--fit-fd-from", type=int, default=401, help="smallest fd N of the fits")
    parser.add_argument("--fit-cheb-from", type=int, default=101, help="smallest cheb N of the fits")
    parser.add_argument("--repeats", type=int, default=1, help="runs per (case, N), interleaved (median)")
    parser.add_argument("--json", default=None, help="write the measurements here")
    parser.add_argument("--cli-options", default="", metavar="'OPTIONS'",
                        help="more options for every run, e.g. '--accuracy publication' (default: none)")
    args = parser.parse_args(argv)
    EXTRA[:] = args.cli_options.split()
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; got {args.repeats}")
    if min(args.fd_N + args.cheb_N) < 5:
        parser.error(f"every N must be >= 5; got {min(args.fd_N + args.cheb_N)}")
    cases = list(args.cases)
    rows, floor = measure(cases, args.fd_N, args.cheb_N, args.repeats)
    loads = [x for r in rows for x in r["load"]]
    data = dict(repeats=args.repeats, load=[min(loads), max(loads)], **floor,
                fit_from={"fd": args.fit_fd_from, "cheb": args.fit_cheb_from}, rows=rows,
                python=sys.version.split()[0], cpu_count=os.cpu_count(), cli_options=args.cli_options)
    data["cases"] = summarise(rows, data["fit_from"])
    print(report(data))
    if args.json:
        write_json(args.json, data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
