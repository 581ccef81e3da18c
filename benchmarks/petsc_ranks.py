"""The PETSc engine on 1 and more MPI ranks, against the serial default, and against another checkout of the code.

iCIDR bump2d on N^2 cells to t_end, ``--engine petsc`` with its defaults, as one whole
``mpiexec -n P`` process per line (its wall time is what the user waits for: start-up, kernel
loading, PETSc's set-up, the run). Per rank, from PETSc's log (``-log_view``'s events): the time
in the right-hand side (TSFunctionEval) and in the Jacobian (TSJacobianEval: the scheme's
Jacobian where it is evaluated, and at every Newton system TS's shift I - J of the kept
values), with their counts, the linear solves (KSPSolve) and the preconditioner applications
(PCApply, about the GMRES iterations), and each rank's process CPU time; the slowest rank is what the
run waits for. Ratios are against the first line (the
first code, 1 rank), measured in the same invocation. Beside every timing the accuracy:
max|w|(t_end), l2_velocity(t_end), the mass drift and, relative to the first line, the largest
difference of the max|w| series.

    nice -n 10 python benchmarks/petsc_ranks.py --N 64 --ranks 1 2 [--code DIR ...]
    nice -n 10 python benchmarks/petsc_ranks.py --N 256 512 --t-end 10 --ranks 1 2 --serial --json out.json

``--serial`` measures first, per N, the serial default (``run`` with no engine asked: CVODE,
GMRES preconditioned by the x-Fourier inverse on the 2-D cell) as one whole process of the same
interpreter and thread settings, and states each PETSc line's whole process against it
(``vs serial``) as well as against the first PETSc line. The accuracy beside every line is
also stated against the grid-converged value, where data/sim2d/richardson.json has it (the
Richardson extrapolation of max|w| and the l2 velocity at t = 10, central advection): a PETSc
line and the serial default at the same N and tolerances have the same grid error, so their
errors against it should agree to the time error. ``uptime`` is printed before every line, and
each line's JSON record keeps the load averages before and after it (``load_before``,
``load_after``): on a shared machine the wall times measure the load as much as the code, the
process CPU times much less.

The launcher is the mpiexec of PETSc's own MPI (``engines.petsc.mpiexec()``), not the first on
PATH. ``--code DIR`` (repeatable) runs another checkout (PYTHONPATH=DIR), e.g. the code before a change
exported by ``git archive COMMIT | tar -x -C DIR``; the default is this checkout.
"""

import argparse
import json
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from provenance import write_json

ROOT = pathlib.Path(__file__).resolve().parents[1]
EVENTS = ("TSFunctionEval", "TSJacobianEval", "KSPSolve", "PCApply", "PCSetUp", "PCSetUpOnBlocks", "MatMult", "TSStep")
#: the thread settings of every child: one BLAS thread (PETSc's vector operations call OpenBLAS,
#: whose spinning threads took 10x their time on the loaded machine)
THREADS = dict(OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")


def serial_child(N: int, t_end: float, out: str) -> None:
    """The serial default on one whole process (the parent times it)."""
    from icidr_pde import run

    r = run("icidr", "bump2d", t_end=t_end, N=(N, N), progress=False,
            times=["0", str(t_end)], series_times=list(np.linspace(0, t_end, 21)[1:]))
    d = r.to_dict()
    write_json(out, dict(wall_s=r.wall_s, steps=r.n_steps, n_jac=r.n_jac, method=r.method, ranks=1,
                         linear_solver=r.settings["linear_solver"], max_w=float(r.max_w_series[-1]),
                         l2=d["l2_velocity"][str(t_end)], mass_drift=r.mass_drift, series=list(map(float, r.max_w_series)),
                         compile_s=r.compile_s, cpu_s=time.process_time(),
                         rss_mib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024), stamp=False, indent=None)


def converged(t_end: float) -> dict:
    """The grid-converged max|w| and l2 velocity at t_end (data/sim2d/richardson.json, central), or {}."""
    path = ROOT / "data" / "sim2d" / "richardson.json"
    try:
        schemes = json.loads(path.read_text())["schemes"]["central"]
        return {q: schemes[q][f"{t_end:g}"]["q_inf"] for q in ("max_w", "l2_velocity")}
    except (OSError, KeyError, ValueError):
        return {}


def serial(N: int, t_end: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "s")
        env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg", **THREADS)
        start = time.perf_counter()
        subprocess.run([sys.executable, __file__, "--serial-child", str(N), str(t_end), out], env=env, check=True)
        whole = time.perf_counter() - start
        r = json.loads(pathlib.Path(out).read_text())
    r["process_s"] = whole
    return r


def child(N: int, t_end: float, out: str) -> None:
    from petsc4py import PETSc

    PETSc.Log.begin()
    from icidr_pde import run

    r = run("icidr", "bump2d", t_end=t_end, N=(N, N), engine="petsc", progress=False,
            times=["0", str(t_end)], series_times=list(np.linspace(0, t_end, 21)[1:]))
    info = {name: PETSc.Log.Event(name).getPerfInfo() for name in EVENTS}
    rank = PETSc.COMM_WORLD.rank
    record = {"rank": rank, "cpu_s": time.process_time(), **{f"{name}_s": float(info[name]["time"]) for name in EVENTS},
              **{f"{name}_n": int(info[name]["count"]) for name in EVENTS}}
    for name in ("TSStep", "KSPSolve"):  # MPI traffic inside the steps, and in the Krylov solves
        record.update({f"{name}_reductions": info[name]["numReductions"], f"{name}_messages": info[name]["numMessages"],
                       f"{name}_bytes": info[name]["messageLength"]})
    if rank == 0:
        d = r.to_dict()
        record.update(wall_s=r.wall_s, steps=r.n_steps, n_jac=r.n_jac, method=r.method, ranks=r.settings.get("ranks"),
                      linear_solver=r.settings["linear_solver"], max_w=float(r.max_w_series[-1]),
                      l2=d["l2_velocity"][str(t_end)], mass_drift=r.mass_drift, series=list(map(float, r.max_w_series)),
                      compile_s=r.compile_s, rss_mib=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    write_json(f"{out}.{rank}", record, stamp=False, indent=None)  # to the parent, not a measurement


def launcher() -> str:
    """The mpiexec of PETSc's MPI (this checkout's engines.petsc.mpiexec), not the first on PATH."""
    sys.path.insert(0, str(ROOT))
    from icidr_pde.engines.petsc import mpiexec

    return mpiexec() or "mpiexec"


def ranks_process(arguments: list, ranks: int, code: str, **more_env) -> tuple[dict, float]:
    """One whole ``mpiexec -n ranks python ARGUMENTS OUT`` process of the `code` checkout: the JSON
    files its ranks wrote, OUT.<name>, by name, and the process's wall time."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r")
        env = dict(os.environ, PYTHONPATH=code, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                   OMPI_MCA_mpi_yield_when_idle="1", MPLBACKEND="Agg", **THREADS, **more_env)
        start = time.perf_counter()
        subprocess.run([launcher(), "-n", str(ranks), sys.executable, *arguments, out], env=env, check=True)
        whole = time.perf_counter() - start
        files = {path.name[len("r."):]: json.loads(path.read_text()) for path in pathlib.Path(tmp).glob("r.*")}
    return files, whole


def one(code: str, ranks: int, N: int, t_end: float) -> dict:
    files, whole = ranks_process([__file__, "--child", str(N), str(t_end)], ranks, code)
    per_rank = [files[str(r)] for r in range(ranks)]
    first = per_rank[0]
    first["process_s"] = whole
    first["cpu_ranks_s"] = [round(p["cpu_s"], 1) for p in per_rank]
    for name in EVENTS:
        first[f"{name}_max_s"] = max(p[f"{name}_s"] for p in per_rank)
        first[f"{name}_ranks_s"] = [round(p[f"{name}_s"], 3) for p in per_rank]
    return first


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--serial-child":
        serial_child(int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--N", type=int, nargs="+", default=[64])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--t-end", type=float, default=2.0)
    ap.add_argument("--code", action="append", default=None, help="checkout to run (PYTHONPATH); default: this one")
    ap.add_argument("--serial", action="store_true", help="measure the serial default first, per N")
    ap.add_argument("--json", default=None, help="write every line's record here")
    args = ap.parse_args()
    codes = args.code or [str(ROOT)]
    limit = converged(args.t_end)
    lines = []

    def accuracy(r) -> str:
        if not limit:
            return ""
        return (f"; against the grid-converged value: max|w| {(r['max_w'] - limit['max_w']) / limit['max_w']:+.2e}, "
                f"l2_velocity {(r['l2'] - limit['l2_velocity']) / limit['l2_velocity']:+.2e}")

    for N in args.N:
        base, baseline = None, None
        if args.serial:
            print(f"uptime: {os.popen('uptime').read().strip()}", flush=True)
            load = os.getloadavg()
            baseline = serial(N, args.t_end)
            lines.append(dict(baseline, N=N, code=str(ROOT), engine="serial default", load_before=load,
                              load_after=os.getloadavg()))
            print(f"N={N}^2 serial default ({baseline['linear_solver']}, {baseline['method']}): process "
                  f"{baseline['process_s']:.1f} s, solve {baseline['wall_s']:.1f} s, {baseline['steps']} steps, "
                  f"process CPU {baseline['cpu_s']:.1f} s, peak RSS {baseline['rss_mib']:.0f} MiB; "
                  f"max|w|({args.t_end:g}) {baseline['max_w']:.6e}, l2_velocity {baseline['l2']:.6e}, "
                  f"mass drift {baseline['mass_drift']:.1e}{accuracy(baseline)}", flush=True)
        for code in codes:
            for ranks in args.ranks:
                print(f"uptime: {os.popen('uptime').read().strip()}", flush=True)
                load = os.getloadavg()
                r = one(code, ranks, N, args.t_end)
                lines.append(dict(r, N=N, code=code, engine="petsc", load_before=load, load_after=os.getloadavg()))
                base = base or r
                against = "" if baseline is None else (
                    f", {r['process_s'] / baseline['process_s']:.2f}x the serial default's process, max|w| "
                    f"{(r['max_w'] - baseline['max_w']) / baseline['max_w']:+.1e} and l2_velocity "
                    f"{(r['l2'] - baseline['l2']) / baseline['l2']:+.1e} from it")
                dev = np.max(np.abs(np.array(r["series"]) - base["series"])) / np.max(np.abs(base["series"]))
                print(f"N={N}^2 code={code} ranks={ranks} ({r['linear_solver']}, {r['method']}, settings.ranks "
                      f"{r['ranks']}): process {r['process_s']:.1f} s ({base['process_s'] / r['process_s']:.2f}x), "
                      f"solve {r['wall_s']:.1f} s ({base['wall_s'] / r['wall_s']:.2f}x), {r['steps']} steps, "
                      f"{r['n_jac']} Jacobians; RHS per rank {r['TSFunctionEval_ranks_s']} s "
                      f"({r['TSFunctionEval_n']} calls), Jacobian per rank {r['TSJacobianEval_ranks_s']} s "
                      f"({r['TSJacobianEval_n']} calls); KSPSolve per rank {r['KSPSolve_ranks_s']} s "
                      f"({r['PCApply_n']} preconditioner applications); process CPU per rank {r['cpu_ranks_s']} s; "
                      f"peak RSS rank 0 {r['rss_mib']:.0f} MiB; "
                      f"max|w|({args.t_end:g}) {r['max_w']:.6e}, l2_velocity {r['l2']:.6e}, "
                      f"mass drift {r['mass_drift']:.1e}, max|w| series vs first line {dev:.1e}"
                      f"{against}{accuracy(r)}", flush=True)
    if args.json:
        write_json(args.json, dict(t_end=args.t_end, converged=limit, lines=lines))


if __name__ == "__main__":
    main()
