"""A weak-scaling MODEL of the PETSc engine on 64-1024 ranks, from per-rank costs measured here.

Not a measurement of many ranks (this machine has 2 cores): it measures, as whole ``mpiexec``
processes (benchmarks/petsc_ranks.py's child, PETSc's log), iCIDR bump2d to t_end

* on 1 rank at 32^2, 64^2 and 128^2 cells: the cost of one right-hand side, one Jacobian
  evaluation (TSJacobianEval per call), one Newton system's preconditioner set-up (PCSetUp) and
  one Krylov iteration (KSPSolve less PCSetUp, per preconditioner application), at each size
  per cell; the steps, Newton systems and preconditioner applications per Newton system, i.e.
  how they grow with the grid; the peak memory per rank (every rank still builds the whole
  grid's scheme, state and Jacobian pattern);
* on 2 ranks at 64^2 and 128^2: the growth of the preconditioner applications from 1 to 2
  ranks (block Jacobi: one block per rank), and the MPI reductions per step (inside TSStep)
  per Krylov iteration;

for the engine's default (bjacobi/ILU(0)) and for GAMG (``-pc_type gamg``). From these, at a
fixed number of cells per rank (``--cells-per-rank``, default 64^2), it models P = 64..1024
ranks, the grid sqrt(P n) cells a side:

* steps and Newton systems grow with the grid side as measured over 32^2..128^2 (a power law
  fitted to the three sizes), applications per Newton system too, times (P/1)^r for the ranks'
  blocks with r = log2(apps at 2 ranks / apps at 1 rank) measured at the largest size
  (ASSUMPTION: the growth seen from 1 to 2 ranks goes on per doubling);
* compute per rank per step: the per-cell costs at the fixed n (measured at that size on 1
  rank: no contention for memory bandwidth between ranks is assumed);
* halo exchanges: one per right-hand side and one per matrix-vector product (MatMult calls
  per Krylov iteration measured), each a block of sqrt(n) x sqrt(n) cells sending its 4 edges
  and 4 corners (box stencil of width 1, 3 values of 8 bytes per cell) to 8 neighbours: 8
  messages of latency ALPHA and the bytes at BANDWIDTH;
* reductions: the measured reductions per Krylov iteration (and per step besides), each an
  allreduce of a few numbers costing 2 ALPHA log2(P) (recursive doubling), and the engine's
  one reduction per step (state check and interrupts);
* the snapshots: a gather of the whole state to every rank (24 N^2 bytes at BANDWIDTH)
  per snapshot; the memory per rank: linear in the WHOLE grid's cells (fitted to the three
  sizes): what is still replicated.

ASSUMPTIONS named, not measured: ALPHA = 2 us per message (an InfiniBand-class network; shared
memory within a node is faster), BANDWIDTH = 10 GB/s per rank, no overlap of communication
with computation, no load imbalance, the same time step sequence on P ranks as measured at
that grid size's fit. The table is a model; only its inputs are measurements.

    nice -n 10 python benchmarks/petsc_weak_model.py [--t-end 1] [--cells-per-rank 4096] [--json M.json]
    python benchmarks/petsc_weak_model.py --measured M.json [--cells-per-rank 16384]   # the model again

``--json`` keeps the measurements; ``--measured`` models from kept ones without running.
"""

import argparse
import json
import math
import os
import pathlib
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from petsc_ranks import ROOT, one  # noqa: E402
from provenance import write_json  # noqa: E402

ALPHA = 2e-6  # s per message (ASSUMPTION)
BANDWIDTH = 10e9  # bytes/s per rank (ASSUMPTION)
DOF, BYTES = 3, 8
SIZES = (32, 64, 128)
GMRES_RESTART = 30  # PETSc's default: beyond it (marked *) GMRES restarts, and grows faster than fitted
RANKS = (64, 128, 256, 512, 1024)
PRECONDITIONERS = {"bjacobi/ILU(0)": "", "gamg": "-pc_type gamg -options_left 0"}  # (the default's -sub_pc_type unused)


def measure(options: str, N: int, ranks: int, t_end: float) -> dict:
    os.environ["PETSC_OPTIONS"] = options
    r = one(str(ROOT), ranks, N, t_end)
    solves = max(r["KSPSolve_n"], 1)
    setup = r["PCSetUp_s"] + r["PCSetUpOnBlocks_s"]  # PCSetUpOnBlocks: block Jacobi's ILU factorisations
    apps = r["PCApply_n"]
    return dict(N=N, ranks=ranks, steps=r["steps"], solves=solves, apps_per_solve=apps / solves,
                rhs_s=r["TSFunctionEval_s"] / max(r["TSFunctionEval_n"], 1), rhs_per_step=r["TSFunctionEval_n"] / r["steps"],
                jac_s=r["TSJacobianEval_s"] / max(r["TSJacobianEval_n"], 1), jac_per_step=r["TSJacobianEval_n"] / r["steps"],
                setup_s=setup / solves, iteration_s=(r["KSPSolve_s"] - setup) / max(apps, 1),
                matmult_per_app=r["MatMult_n"] / max(apps, 1),
                other_reductions_per_step=(r["TSStep_reductions"] - r["KSPSolve_reductions"]) / r["steps"],
                krylov_reductions_per_app=r["KSPSolve_reductions"] / max(apps, 1),
                reductions_per_step=r["TSStep_reductions"] / r["steps"],
                messages_per_step=r["TSStep_messages"] / r["steps"], bytes_per_step=r["TSStep_bytes"] / r["steps"],
                compile_s=r["compile_s"], rss_mib=r["rss_mib"], max_w=r["max_w"], process_s=r["process_s"])


def power_law(x, y) -> float:
    """The exponent q of y ~ x^q, least squares in logs."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def model(name: str, one_rank: list, two: dict, n: int, t_end: float) -> None:
    side = math.isqrt(n)
    sides = [m["N"] for m in one_rank]
    at_n = min(one_rank, key=lambda m: abs(m["N"] - side))
    q_steps = power_law(sides, [m["steps"] for m in one_rank])
    q_solves = power_law(sides, [m["solves"] / m["steps"] for m in one_rank])
    q_apps = power_law(sides, [m["apps_per_solve"] for m in one_rank])
    base = max(one_rank, key=lambda m: m["N"])
    r_blocks = math.log2(two["apps_per_solve"] / base["apps_per_solve"])
    rss_per_cell = np.polyfit([m["N"] ** 2 for m in one_rank], [m["rss_mib"] for m in one_rank], 1)
    print(f"\n{name}: measured growth over {sides[0]}^2..{sides[-1]}^2 on 1 rank: steps ~ N^{q_steps:.2f}, "
          f"Newton systems per step ~ N^{q_solves:.2f}, preconditioner applications per system ~ N^{q_apps:.2f}; "
          f"1 -> 2 ranks at {two['N']}^2: applications per system {base['apps_per_solve']:.2f} -> "
          f"{two['apps_per_solve']:.2f} (r = {r_blocks:.2f} per doubling); reductions (2 ranks) in the Krylov "
          f"solves {two['krylov_reductions_per_app']:.2f} per application, besides {two['other_reductions_per_step']:.1f} "
          f"per step; "
          f"per-rank costs at {at_n['N']}^2: RHS {at_n['rhs_s'] * 1e3:.2f} ms, Jacobian {at_n['jac_s'] * 1e3:.2f} ms, "
          f"PC set-up {at_n['setup_s'] * 1e3:.2f} ms per Newton system, Krylov iteration {at_n['iteration_s'] * 1e3:.3f} ms")
    print("| ranks P | grid | steps | PC apps/system | compute/step | halo/step | allreduce/step | step | "
          "weak efficiency | run (t_end) | gather/snapshot | memory/rank |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    exchange = 8 * ALPHA + DOF * BYTES * (4 * side + 4) / BANDWIDTH  # 4 edges and 4 corners, 8 messages
    reference = None
    for P in (1,) + RANKS:
        N = side * math.sqrt(P)
        grow = N / at_n["N"]
        steps = at_n["steps"] * grow ** q_steps
        solves_per_step = at_n["solves"] / at_n["steps"] * grow ** q_solves
        apps = at_n["apps_per_solve"] * grow ** q_apps * (P ** r_blocks if P > 1 else 1.0)
        compute = (at_n["rhs_per_step"] * at_n["rhs_s"] + at_n["jac_per_step"] * at_n["jac_s"]
                   + solves_per_step * (at_n["setup_s"] + apps * at_n["iteration_s"]))
        exchanges = at_n["rhs_per_step"] + solves_per_step * apps * at_n["matmult_per_app"]
        halo = 0.0 if P == 1 else exchanges * exchange
        reductions = two["other_reductions_per_step"] + two["krylov_reductions_per_app"] * solves_per_step * apps + 1
        allreduce = 0.0 if P == 1 else reductions * 2 * ALPHA * math.log2(P)
        step = compute + halo + allreduce
        reference = reference or step
        gather = 0.0 if P == 1 else DOF * BYTES * N * N / BANDWIDTH + ALPHA * math.log2(P)
        rss = float(np.polyval(rss_per_cell, N * N))
        restarts = "*" if apps > GMRES_RESTART else ""
        print(f"| {P} | {N:.0f}^2 | {steps:.0f} | {apps:.1f}{restarts} | {compute * 1e3:.1f} ms | {halo * 1e3:.2f} ms | "
              f"{allreduce * 1e3:.2f} ms | {step * 1e3:.1f} ms | {reference / step:.2f} | "
              f"{steps * step:.0f} s | {gather * 1e3:.1f} ms | {rss:.0f} MiB |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--cells-per-rank", type=int, default=64 * 64)
    ap.add_argument("--pc", choices=sorted(PRECONDITIONERS), nargs="+", default=sorted(PRECONDITIONERS))
    ap.add_argument("--json", default=None, help="keep the measurements in this file")
    ap.add_argument("--measured", default=None, help="model from the measurements kept by --json (no runs)")
    args = ap.parse_args()
    if args.measured:
        kept = json.loads(pathlib.Path(args.measured).read_text())
        print(f"measured: {args.measured} ({kept['uptime']})")
    else:
        kept = {"uptime": os.popen("uptime").read().strip(), "t_end": args.t_end, "pc": {}}
        print(f"uptime: {kept['uptime']}")
    print(f"assumptions: latency {ALPHA * 1e6:g} us per message, bandwidth {BANDWIDTH / 1e9:g} GB/s per rank; "
          f"{args.cells_per_rank} cells per rank; iCIDR bump2d to t = {kept['t_end']:g}")
    for name in args.pc:
        if args.measured:
            one_rank, two = kept["pc"][name]["one_rank"], kept["pc"][name]["two"]
        else:
            one_rank, two = run_measurements(name, args.t_end)
            kept["pc"][name] = {"one_rank": one_rank, "two": two}
            if args.json:
                write_json(args.json, kept)
        model(name, one_rank, two, args.cells_per_rank, kept["t_end"])
    os.environ.pop("PETSC_OPTIONS", None)


def run_measurements(name: str, t_end: float):
    options = PRECONDITIONERS[name]
    one_rank = []
    for N in SIZES:
        m = measure(options, N, 1, t_end)
        one_rank.append(m)
        print(f"measured {name} {N}^2 1 rank: process {m['process_s']:.1f} s, {m['steps']} steps, "
              f"{m['solves']} Newton systems, {m['apps_per_solve']:.2f} PC applications per system, "
              f"peak memory {m['rss_mib']:.0f} MiB, max|w|({t_end:g}) {m['max_w']:.6e}", flush=True)
    two = measure(options, SIZES[-1], 2, t_end)
    print(f"measured {name} {SIZES[-1]}^2 2 ranks: process {two['process_s']:.1f} s, {two['steps']} steps, "
          f"{two['apps_per_solve']:.2f} PC applications per system, {two['reductions_per_step']:.1f} reductions "
          f"and {two['messages_per_step']:.0f} messages ({two['bytes_per_step'] / 1e3:.0f} kB) per step per rank, "
          f"max|w|({t_end:g}) {two['max_w']:.6e}", flush=True)
    return one_rank, two


if __name__ == "__main__":
    main()
