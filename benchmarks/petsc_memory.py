"""Peak memory of each rank of the PETSc engine on 1, 2 and 4 MPI ranks, against another checkout.

iCIDR bump2d on N^2 cells to a short t_end (a few steps: the set-up and the first steps hold
what a long run holds), ``--engine petsc`` with its defaults, as one whole ``mpiexec -n P``
process per line. Each rank reports its own peak resident set (``getrusage(RUSAGE_SELF)
.ru_maxrss``, the whole process: Python, the imports, PETSc, the set-up and the run) and its
resident set after the imports (the floor that does not depend on the grid); the parent
gathers them from one file per rank. Per cell, the peak above that floor: ``(peak - floor) /
(N^2 / P)`` divides by the ranks where each rank holds only its own block, and is the whole
grid's where each builds it all. The first checkout's 1-rank line is the baseline of each N,
measured in the same invocation; beside every line the accuracy: max|w|(t_end) and the mass
drift, and the relative difference of max|w|(t_end) from the baseline.

    nice -n 10 python benchmarks/petsc_memory.py --N 512 1024 --ranks 1 2 4 --code DIR_BEFORE --code .

A line whose estimated memory (all ranks above the imports, from the lines of that code measured
before it at that N) exceeds the memory available (``MemAvailable`` less a margin) is skipped and
says so: the machine is shared (this estimate, not the run's own memory check, whose figure for
the PETSc engine is the whole grid's on one process: ICIDR_PDE_MEMORY is set out of its way).
``--code DIR`` (repeatable) runs another checkout (PYTHONPATH=DIR),
e.g. the code before a change exported by ``git archive COMMIT | tar -x -C DIR``; the default is
this checkout. Writes data/benchmarks/petsc_memory.json (``--out``; ``--append`` adds to its lines,
each keeping the provenance of the invocation that measured it: a table measured in parts on a
busy machine).
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

from provenance import write_json

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: memory left to the machine's other work when deciding whether a line fits (GiB)
MARGIN_GIB = 3.0


def _rss_mib() -> float:
    """The resident set of this process now (MiB), from /proc."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def child(N: int, t_end: float, out: str) -> None:
    import resource

    from petsc4py import PETSc

    import icidr_pde.engines.petsc  # noqa: F401  (the engine's imports: part of the floor)
    from icidr_pde import run
    import pde  # noqa: F401  (py-pde, numba, scipy: the py-pde path's imports, part of the floor)

    floor = _rss_mib()
    start = time.perf_counter()
    r = run("icidr", "bump2d", t_end=t_end, N=(N, N), engine="petsc", progress=False, times=[str(t_end)],
            series_times=[t_end])
    wall = time.perf_counter() - start
    rank = PETSc.COMM_WORLD.rank
    record = {"rank": rank, "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
              "floor_mib": floor, "process_s": wall}
    if rank == 0:
        record.update(steps=r.n_steps, t_final=r.t_final, max_w=float(r.max_w[-1]), mass_drift=r.mass_drift,
                      ranks=r.settings.get("ranks"), blew_up=r.blew_up)
    write_json(f"{out}.{rank}", record, stamp=False, indent=None)  # to the parent, not a measurement


def launcher() -> str:
    """The mpiexec of PETSc's MPI (this checkout's engines.petsc.mpiexec), not the first on PATH."""
    sys.path.insert(0, str(ROOT))
    from icidr_pde.engines.petsc import mpiexec

    return mpiexec() or "mpiexec"


def available_gib() -> float:
    with open("/proc/meminfo") as fh:
        for line in fh:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) / 2**20
    return float("inf")


def one(code: str, ranks: int, N: int, t_end: float) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "r")
        env = dict(os.environ, PYTHONPATH=code, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                   OMPI_MCA_mpi_yield_when_idle="1", MPLBACKEND="Agg", OMP_NUM_THREADS="1",
                   OPENBLAS_NUM_THREADS="1", ICIDR_PDE_MEMORY=str(2**50))  # the estimate below guards, not the run's
        command = [launcher(), "--oversubscribe", "-n", str(ranks), sys.executable, __file__, "--child", str(N),
                   str(t_end), out]
        start = time.perf_counter()
        subprocess.run(command, env=env, check=True)
        whole = time.perf_counter() - start
        per_rank = [json.loads(pathlib.Path(f"{out}.{r}").read_text()) for r in range(ranks)]
    first = dict(per_rank[0])
    cells = N * N / ranks
    first.update(code=code, N=N, P=ranks, whole_process_s=whole, load=os.getloadavg(),
                 peak_mib_ranks=[round(p["peak_mib"], 1) for p in per_rank],
                 floor_mib_ranks=[round(p["floor_mib"], 1) for p in per_rank],
                 kb_per_cell_ranks=[round((p["peak_mib"] - p["floor_mib"]) * 2**20 / cells / 1e3, 2)
                                    for p in per_rank],
                 above_floor_gib=sum(p["peak_mib"] - p["floor_mib"] for p in per_rank) / 1024)
    return first


def _estimate(measured, ranks) -> float:
    """All ranks' memory above the imports (GiB) on `ranks` ranks, from the lines measured: the
    last one's scaled by the ranks to the power the last two measured (1, each rank holding the
    whole grid, where only one line is known: the cautious guess)."""
    (r1, m1), (r2, m2) = measured[-2] if len(measured) > 1 else (1, 1.0), measured[-1]
    power = 1.0 if len(measured) < 2 or r1 == r2 else min(1.0, max(0.0, np.log(m2 / m1) / np.log(r2 / r1)))
    return m2 * (ranks / r2) ** power


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--N", type=int, nargs="+", default=[512])
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4])
    ap.add_argument("--t-end", type=float, default=0.1)
    ap.add_argument("--code", action="append", default=None, help="checkout to run (PYTHONPATH); default: this one")
    ap.add_argument("--out", default=str(ROOT / "data" / "benchmarks" / "petsc_memory.json"))
    ap.add_argument("--append", action="store_true",
                    help="keep the lines of --out (each with the provenance of the run that measured it)")
    args = ap.parse_args()
    codes = [str(pathlib.Path(c).resolve()) for c in (args.code or [str(ROOT)])]
    print(f"uptime: {os.popen('uptime').read().strip()}", flush=True)
    lines, skipped = [], []
    if args.append and os.path.exists(args.out):
        kept = json.loads(pathlib.Path(args.out).read_text())
        lines = [dict(line, provenance=line.get("provenance", kept.get("provenance"))) for line in kept["lines"]]
        skipped = kept.get("skipped", [])
    for N in args.N:
        base = None
        for code in codes:
            measured = []  # (ranks, all ranks' peak above the imports, GiB) of this code at this N
            for ranks in args.ranks:
                free = available_gib()
                if measured:
                    estimate = _estimate(measured, ranks)
                    if estimate > free - MARGIN_GIB:
                        why = (f"N={N}^2 code={code} ranks={ranks}: skipped, estimated {estimate:.1f} GiB above the "
                               f"imports > {free:.1f} GiB available less {MARGIN_GIB} GiB")
                        print(why, flush=True)
                        skipped.append(why)
                        continue
                r = one(code, ranks, N, args.t_end)
                r["available_gib_before"] = round(free, 1)
                base = base or r
                measured.append((ranks, r["above_floor_gib"]))
                dev = abs(r["max_w"] - base["max_w"]) / abs(base["max_w"])
                lines.append(r)
                print(f"N={N}^2 code={code} ranks={ranks}: peak RSS per rank {r['peak_mib_ranks']} MiB "
                      f"(after imports {r['floor_mib_ranks']} MiB), above the imports per cell of a rank "
                      f"{r['kb_per_cell_ranks']} kB; whole process {r['whole_process_s']:.0f} s, load "
                      f"{r['load'][0]:.1f}; {r['steps']} steps to t = {r['t_final']:g}, max|w| {r['max_w']:.10e} "
                      f"(vs first line {dev:.1e}), mass drift {r['mass_drift']:.1e}", flush=True)
                write_json(args.out, {"t_end": args.t_end, "lines": lines, "skipped": skipped})


if __name__ == "__main__":
    main()
