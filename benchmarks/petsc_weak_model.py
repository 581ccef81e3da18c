"""A weak-scaling MODEL of the PETSc engine on 64-1024 ranks, from per-rank costs measured here.

``--pc xfourier`` (the default): the engine with the x-Fourier preconditioner distributed as a
shell PC (z-slabs; each application a local x-FFT, one all-to-all transpose to wave-number slabs,
the banded solves of its wave numbers over all z, the transpose back; :func:`xfourier_main`, its
docstring says what is measured and what is assumed: the counts per step and the calibration
are the PETSc engine's own). ``--pc "bjacobi/ILU(0)" gamg``: the model of the engine's PETSc
preconditioners, measured as below.

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

    nice -n 10 python benchmarks/petsc_weak_model.py                     # x-Fourier: measures, models, writes
                                                                          # data/benchmarks/petsc_weak_model.json
    python benchmarks/petsc_weak_model.py --measured data/benchmarks/petsc_weak_model.json  # the model again
    python benchmarks/petsc_weak_model.py --measured data/benchmarks/petsc_weak_model.json --transpose-bytes-per-cell 12
                                          # the transposes in single precision (--node-bandwidth, --ranks-per-node too)
    nice -n 10 python benchmarks/petsc_weak_model.py --pc "bjacobi/ILU(0)" gamg [--t-end 1] [--cells-per-rank 4096] [--json M.json]
    python benchmarks/petsc_weak_model.py --pc "bjacobi/ILU(0)" gamg --measured M.json [--cells-per-rank 16384]

``--json`` keeps the measurements; ``--measured`` models from kept ones without running.
"""

import argparse
import json
import math
import os
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from petsc_ranks import ROOT, one  # noqa: E402
from provenance import write_json  # noqa: E402

# one core per rank: the band solves' numba threads (read when numba starts) and the BLAS's, one each
for _name in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

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


# --- the x-Fourier preconditioner on PETSc: per-rank costs measured, the network assumed ----------------

#: cells per rank modelled, ranks, and the grids whose serial runs give the counts per step
CELLS_PER_RANK = (64 * 64, 128 * 128, 256 * 256)
XF_RANKS = (1, 64, 256, 1024)
COUNT_SIZES = (32, 64, 128, 256)
#: the network assumed for P >= 64 ranks (NAMED, not measured): a cluster of 64-core nodes on HDR100
#: InfiniBand (100 Gb/s = 12.5 GB/s per node; e.g. the Alliance's Narval, docs.computecanada.ca,
#: "High-performance interconnect": HDR100 to each node, islands of up to 66 nodes non-blocking, so
#: 1024 ranks = 16 nodes lie in one island); ConnectX-6 adapters state sub-0.6 us (NVIDIA's manual),
#: 2 us per MPI message allows for the MPI stack and the switches, as the earlier model did
NET_LATENCY = 2e-6
NODE_BANDWIDTH = 12.5e9
RANKS_PER_NODE = 64
#: bytes per cell that a transpose moves: 3 fields, the real FFT's Nx/2 + 1 complex values of Nx reals
TRANSPOSE_BYTES_PER_CELL = 3 * 16 / 2
XF_TIMES = ["0.5", "1", "2", "5", "10"]


def _best(f, repeat=7, number=1) -> tuple[float, float]:
    """(min, median) seconds per call of f over `repeat` rounds of `number` calls (the min: the
    cost on a core of its own, the nearest a shared machine gives; the median: under its load)."""
    import time

    f()
    rounds = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            f()
        rounds.append((time.perf_counter() - t0) / number)
    return float(np.min(rounds)), float(np.median(rounds))


def _slab(nx: int, nz: int):
    """iCIDR bump2d's scheme on a block of nx x nz cells of the grid's spacing (30 / nx): its
    patch (dof, nx + 2, nz + 2) with x periodic ghosts and z ghosts copied, its Patches, the
    scheme, the state."""
    from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
    from icidr_pde.cells.plane2d.scenes import Bump2DScene

    L = 30.0
    pde = ShearCell2DPDE("icidr")
    scene = Bump2DScene()
    grid = pde.make_grid((nx, nz), L * nz / nx, L=L)
    state = pde.make_state(grid, *scene.initial_condition(pde.nodes(grid)))
    g = np.pad(state.data, ((0, 0), (1, 1), (0, 0)), mode="wrap")
    g = np.ascontiguousarray(np.pad(g, ((0, 0), (0, 0), (1, 1)), mode="edge"))
    return pde, state, pde.patches(state), g


def rank_costs(N: int, P: int, n: int, lin_per_newton: float) -> dict:
    """Seconds per call, (min, median), of what one rank of P does on the N x N grid in z-slabs of
    n cells (N x n/N): the right-hand side (the patch kernel), the Jacobian rows and their
    x-average, the band LU factors of its wave numbers (all of them on 1 rank; ceil((N/2)/P) on P,
    the real k = 0 and k = N/2 sharing one rank), one preconditioner application's FFTs with the
    packing around the transposes and its band solves, and GMRES's vector work per iteration (PETSc's
    classical Gram-Schmidt: j + 1 dot products and axpys of 3n values at the mean Krylov
    dimension j). The serial implementation (engines/linear/xfourier_inverse.py) at these sizes."""
    from icidr_pde.engines.linear import x_average as xa, xfourier_inverse as xf

    nz = n // N
    nzm = max(nz, 4)  # the scheme's grid has 4 rows at least: a thinner slab is timed at 4, scaled by its rows
    pde, state, patches, g = _slab(N, nzm)
    out = np.empty((3, N, nzm))
    rhs = _best(lambda: patches.rates(g, False, False, out), repeat=11, number=5)
    jac = _best(lambda: patches.jacobian(g, False, False), repeat=3)
    J = pde.make_jacobian(state)(0.0, state.data.ravel()).tocsc()
    reach = np.zeros(2, dtype=np.int64)
    xa.columns_reach(J.indptr, J.indices, 3, N, nzm, reach)
    band, dx = int(reach[0]), int(reach[1])
    average = np.zeros((3 * nzm, 2 * band + 1, 2 * dx + 1))
    xavg = _best(lambda: xa.columns_average(J.indptr, J.indices, J.data, 3, N, nzm, average), repeat=9)
    rhs, jac, xavg = ([t * nz / nzm for t in pair] for pair in (rhs, jac, xavg))
    # the band systems of the whole z (3N unknowns) for this rank's wave numbers: the preconditioner of an
    # nxk x N grid has nxk/2 + 1 of them
    modes = N // 2 + 1 if P == 1 else -(-(N // 2) // P)
    nxk = max(4, 2 * (modes - 1)) if P == 1 else max(4, 2 * modes)
    pd, ps, _, _ = _slab(nxk, N)
    Jk = pd.make_jacobian(ps)(0.0, ps.data.ravel())
    pre = xf.XFourierPreconditioner(Jk, (3, nxk, N), 0.05)
    factors = pre.factors
    systems = factors.lu.shape[0]
    gammas = iter(np.linspace(0.05, 0.06, 1000))
    factor = _best(lambda: pre.at(next(gammas)), repeat=7)
    factor = tuple(t * modes / systems for t in factor)
    m = 3 * N
    columns = (np.random.default_rng(0).standard_normal((modes, m)) + 0j)
    lu, rec, piv = factors.lu[:modes], factors.reciprocal[:modes], factors.pivots[:modes]
    if modes > systems:
        raise ValueError(f"{modes} wave numbers asked of {systems} factored")
    work = columns.copy()

    def band_solve():
        work[:] = columns
        xf._band_solve(lu, rec, piv, factors.kl, factors.ku, work)

    band_s = _best(band_solve, repeat=11, number=3)
    slab = np.random.default_rng(1).standard_normal((3, N, nzm))

    def fft_and_packing():
        spectrum = np.fft.rfft(slab, axis=1)                         # (3, N/2 + 1, nz)
        send = np.ascontiguousarray(spectrum.transpose(1, 2, 0))     # by wave number: the transpose's blocks
        back = np.ascontiguousarray(send.transpose(2, 0, 1))         # from the transpose back
        return np.fft.irfft(back, n=N, axis=1)

    fft = [t * nz / nzm for t in _best(fft_and_packing, repeat=11, number=3)]
    k = max(1.0, (lin_per_newton + 1) / 2)  # the mean Krylov dimension of a solve
    V = np.random.default_rng(2).standard_normal((int(round(k)) + 1, 3 * n))
    w = np.empty(3 * n)

    def gram_schmidt():  # the new Krylov vector against the basis: dot products, axpys, its norm
        w[:] = V[-1]
        h = V[:-1] @ w
        w[:] -= h @ V[:-1]
        return np.linalg.norm(w)

    vec = _best(gram_schmidt, repeat=11, number=5)
    return {"N": N, "P": P, "cells_per_rank": n, "slab": [N, nz], "wave_numbers": modes, "band": band,
            "rhs_s": rhs, "jac_s": jac, "xavg_s": xavg, "factor_s": factor, "band_solve_s": band_s, "fft_s": fft,
            "gram_schmidt_s": vec, "krylov_dimension": k, "band_width": [factors.kl, factors.ku],
            "averages_bytes": 3 * N * (2 * band + 1) * (2 * dx + 1) * 8}


def serial_counts(N: int, last: dict) -> dict:
    """CVODE's counters of the serial default (GMRES + the x-Fourier inverse, BDF order 2) on iCIDR
    bump2d N^2 to t = 10, the preset's tolerances: what a step needs (steps, Newton and GMRES
    iterations, right-hand sides, Jacobians, factorizations, preconditioner applications), its
    solve time, max|w| at 0.5 .. 10."""
    import resource
    import time

    from icidr_pde.api import run

    last.clear()
    cpu = time.process_time()
    r = run("icidr", "bump2d", (N, N), 10.0, XF_TIMES, method="CVODE", jacobian="fourier", engine="pde",
            progress=False)
    d = r.to_dict()
    return {"N": N, "linear_solver": r.settings["linear_solver"], "solve_s": d["wall_s"],
            "cpu_s": time.process_time() - cpu, "n_rhs": d["n_rhs"], "max_w": d["max_w"],
            "rtol": r.rtol, "atol": r.atol, "max_order": r.settings.get("max_order"),
            "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, **last}


ALLTOALL_CHILD = """
import json, sys, time
import numpy as np
from petsc4py import PETSc
comm = PETSc.COMM_WORLD
P, r = comm.size, comm.rank
out = []
for L in map(int, sys.argv[2:]):  # doubles per rank, a multiple of P
    x = PETSc.Vec().createMPI((L, None), comm=comm)
    y = x.duplicate()
    start, _ = x.getOwnershipRange()
    block = L // P
    j = np.arange(L)
    # the transpose: block b of rank r goes to rank b's block r
    dest = (j // block) * L + r * block + j % block
    scatter = PETSc.Scatter().create(x, PETSc.IS().createGeneral((start + j).astype(PETSc.IntType)), y,
                                     PETSc.IS().createGeneral(dest.astype(PETSc.IntType)))
    x.setArray(np.arange(L, dtype=float) + start)
    reps = max(5, min(2000, int(2e8 // (8 * L + 1))))
    rounds = []
    for _ in range(7):
        comm.barrier()
        t0 = time.perf_counter()
        for _ in range(reps):
            scatter.scatter(x, y, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        comm.barrier()
        rounds.append((time.perf_counter() - t0) / reps)
    got = y.getArray(readonly=True)
    # what arrived: y's local block b came from rank b's block r (their global indices)
    k = np.arange(L)
    expect = (k // block) * L + r * block + k % block
    ok = bool(np.array_equal(got, expect.astype(float)))
    norms = []
    for _ in range(7):
        comm.barrier()
        t0 = time.perf_counter()
        for _ in range(200):
            x.dot(x)  # not x.norm(): PETSc keeps the norm of an unchanged vector
        norms.append((time.perf_counter() - t0) / 200)
    out.append({"doubles_per_rank": L, "bytes_per_rank": 8 * L, "alltoall_s": [min(rounds), float(np.median(rounds))],
                "allreduce_s": [min(norms), float(np.median(norms))], "transposed_exactly": ok})
    for obj in (scatter, x, y):
        obj.destroy()
if r == 0:
    with open(sys.argv[1], "w") as f:
        json.dump(out, f)
"""


def measure_alltoall(cells) -> list:
    """The transpose of a rank's 24 bytes per cell (the real FFT's complex values of 3 fields)
    between 2 ranks of this machine (PETSc's scatter, shared memory), and an allreduce (VecNorm):
    (min, median) seconds, with a check that every value arrived where the transpose puts it."""
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        script = pathlib.Path(tmp) / "alltoall.py"
        script.write_text(ALLTOALL_CHILD)
        out = pathlib.Path(tmp) / "out.json"
        doubles = [2] + [int(TRANSPOSE_BYTES_PER_CELL * c // 8) for c in cells]
        env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                   OMPI_MCA_mpi_yield_when_idle="1", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
        from petsc_ranks import launcher

        subprocess.run([launcher(), "-n", "2", sys.executable, str(script), str(out), *map(str, doubles)],
                       env=env, check=True)
        return json.loads(out.read_text())


#: the grids whose PETSc runs (1 rank) give the counts per step and the engine's time per step
ENGINE_SIZES = (32, 64, 128, 256, 512)
#: the grid of the 2-rank run of the engine (its reductions, and its counts against 1 rank's)
TWO_RANK_N = 128


def engine_child(N: int, t_end: float, out: str) -> None:
    """benchmarks/petsc_ranks.py's child (the engine under PETSc's log, one whole run), with the
    engine's own counters besides, read when the run path asks the engine for its counts: TS's
    steps, Newton (SNES) and GMRES (KSP) iterations, rejected steps, and the x-Fourier shell's
    averages (one per evaluated Jacobian) and banded factorizations."""
    from petsc_ranks import child

    from icidr_pde.engines import petsc

    counted = {}
    counts, init = petsc.PetscEngine.counts, petsc.PetscEngine.__init__

    def starting(self, *args, **kwargs):  # the integration's CPU time runs from the engine's set-up's end
        init(self, *args, **kwargs)
        counted["integration_cpu_start"] = time.process_time()

    def counting(self):
        ts = self.ts
        counted.update(integration_cpu_s=time.process_time() - counted.pop("integration_cpu_start", 0.0),
                       steps=int(ts.getStepNumber()), newton_iterations=int(ts.getSNESIterations()),
                       gmres_iterations=int(ts.getKSPIterations()), rejected=int(ts.getStepRejections()),
                       snes_failures=int(ts.getSNESFailures()), n_jac=self.n_jac,
                       averages=getattr(self._shell, "n_averages", None),
                       factorizations=getattr(self._shell, "n_factors", None), pc=self.linear_solver)
        return counts(self)

    petsc.PetscEngine.counts, petsc.PetscEngine.__init__ = counting, starting
    if os.environ.get(SINGLE) == "1":
        _single_precision_transposes()
    cpu = time.process_time()
    child(N, t_end, out)
    counted["run_cpu_s"] = time.process_time() - cpu
    from petsc4py import PETSc

    write_json(f"{out}.counts.{PETSc.COMM_WORLD.rank}", counted, stamp=False, indent=None)


#: the environment variable that asks the engine's child for transposes of single-precision values
SINGLE = "WEAK_MODEL_SINGLE_PRECISION_TRANSPOSES"


def _single_precision_transposes() -> None:
    """What the x-Fourier shell's preconditioner gives when its two transposes carry single-precision
    values (12 bytes a cell instead of 24): the vector each transpose sends is rounded to float32
    just before it is sent (it is the shell's scratch, not read again), so what arrives is what
    float32 messages would bring. Not the engine's code: a what-if of this benchmark, for the
    model's ``--transpose-bytes-per-cell 12``."""
    from icidr_pde.engines.linear import xfourier_shell

    class Rounded:
        def __init__(self, scatter):
            self.inner = scatter

        def scatter(self, source, target, addv=None, mode=None):
            values = source.getArray()
            values[:] = values.astype(np.float32)
            self.inner.scatter(source, target, addv=addv, mode=mode)

    init = xfourier_shell.XFourierShell.__init__

    def rounding(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.transpose = Rounded(self.transpose)

    xfourier_shell.XFourierShell.__init__ = rounding


def engine_run(N: int, ranks: int, t_end: float = 10.0, single: bool = False) -> dict:
    """One whole ``mpiexec -n ranks`` process of the engine (its defaults: the x-Fourier shell),
    iCIDR bump2d N^2 to t_end: rank 0's record of petsc_ranks.py's child (PETSc's events, the
    solve's wall time, max|w|) with the engine's counters (:func:`engine_child`), the process's wall
    time and each rank's CPU."""
    from petsc_ranks import ranks_process

    files, whole = ranks_process([__file__, "--engine-child", str(N), str(t_end)], ranks, str(ROOT), PETSC_OPTIONS="",
                                 **{SINGLE: "1" if single else "0"})
    per_rank, counted = [files[str(r)] for r in range(ranks)], files["counts.0"]
    r = per_rank[0]
    keep = ("wall_s", "steps", "n_jac", "linear_solver", "max_w", "l2", "mass_drift", "compile_s", "rss_mib")
    events = {k: v for k, v in r.items() if k.endswith(("_s", "_n", "_reductions", "_messages", "_bytes"))
              and k.split("_")[0] in EVENTS}
    return {"N": N, "ranks": ranks, "t_end": t_end, "single_precision_transposes": single,
            **{k: r[k] for k in keep}, **counted, "events": events,
            "events_ranks_s": {name: [round(p[f"{name}_s"], 3) for p in per_rank] for name in EVENTS},
            "process_s": whole, "cpu_ranks_s": [round(p["cpu_s"], 2) for p in per_rank],
            "series": r["series"]}


def engine_counts(runs: list) -> dict:
    """Per step, from the engine's runs: what the model counts (GMRES, PC applications, RHS,
    Jacobians, factorizations, Newton iterations) and its time per step."""
    out = []
    for r in runs:
        e, steps = r["events"], r["steps"]
        out.append({"N": r["N"], "steps": steps, "newton": r["newton_iterations"] / steps,
                    "gmres": r["gmres_iterations"] / steps, "applications": e["PCApply_n"] / steps,
                    "rhs": e["TSFunctionEval_n"] / steps, "jacobians": r["n_jac"] / steps,
                    "factorizations": r["factorizations"] / steps, "step_s": r["integration_cpu_s"] / steps})
    return out


EVENTS = ("TSFunctionEval", "TSJacobianEval", "KSPSolve", "PCApply", "PCSetUp", "MatMult", "TSStep")


def measure_xfourier(sizes=ENGINE_SIZES) -> dict:
    from amg2d import _counting  # CVODE's counters of the last run, as amg2d.py records them

    from icidr_pde.studies.parallel import limit_blas_threads

    limit_blas_threads(1)
    engine = []
    for N in sizes:
        r = engine_run(N, 1)
        engine.append(r)
        print(f"measured PETSc engine {N}^2 to t = 10, 1 rank ({r['linear_solver']}): process {r['process_s']:.1f} s, "
              f"solve {r['wall_s']:.2f} s, CPU {r['integration_cpu_s']:.2f} s the integration, {r['cpu_ranks_s'][0]:.1f} s "
              f"the process, {r['steps']} steps "
              f"({r['rejected']} rejected), {r['newton_iterations']} Newton, {r['gmres_iterations']} GMRES, "
              f"{r['events']['PCApply_n']} PC applications, {r['events']['TSFunctionEval_n']} RHS, {r['n_jac']} "
              f"Jacobians, {r['factorizations']} factorizations; max|w|(10) {r['max_w']:.6e}", flush=True)
    two = engine_run(TWO_RANK_N, 2)
    one_rank = next((r for r in engine if r["N"] == TWO_RANK_N), None)
    same = one_rank is not None and all(two[k] == one_rank[k] for k in ("steps", "newton_iterations", "gmres_iterations",
                                                                        "n_jac", "factorizations"))
    deviation = None if one_rank is None else float(
        np.max(np.abs(np.subtract(two["series"], one_rank["series"]))) / np.max(np.abs(one_rank["series"])))
    e = two["events"]
    reductions = {"N": TWO_RANK_N, "t_end": 10.0, "steps": two["steps"],
                  # inside KSPSolve: each GMRES iteration's and each solve's first residual's (one preconditioner
                  # application each, left-preconditioned: applications = GMRES iterations + Newton systems)
                  "krylov_reductions_per_application": e["KSPSolve_reductions"] / max(e["PCApply_n"], 1),
                  "other_reductions_per_step": (e["TSStep_reductions"] - e["KSPSolve_reductions"]) / two["steps"],
                  "messages_per_application": e["KSPSolve_messages"] / max(e["PCApply_n"], 1),
                  "counts_as_1_rank": same, "max_w_series_vs_1_rank": deviation}
    print(f"measured PETSc engine {TWO_RANK_N}^2 to t = 10, 2 ranks: process {two['process_s']:.1f} s, CPU per rank "
          f"{two['cpu_ranks_s']} s, {two['steps']} steps, {two['newton_iterations']} Newton, {two['gmres_iterations']} "
          f"GMRES, {e['PCApply_n']} PC applications (the same counts as 1 rank: {same}; max|w| series within "
          f"{float('nan') if deviation is None else deviation:.1e} of 1 rank's); {reductions['krylov_reductions_per_application']:.2f} reductions per PC application "
          f"in the Krylov solves, "
          f"{reductions['other_reductions_per_step']:.1f} per step besides", flush=True)
    single = engine_run(TWO_RANK_N, 2, single=True)
    single_deviation = float(np.max(np.abs(np.subtract(single["series"], two["series"]))) / np.max(np.abs(two["series"])))
    single_same = all(single[k] == two[k] for k in ("steps", "newton_iterations", "gmres_iterations", "n_jac"))
    print(f"measured PETSc engine {TWO_RANK_N}^2 to t = 10, 2 ranks, the transposes' values in single precision "
          f"(a what-if, not the engine's code): {single['steps']} steps, {single['newton_iterations']} Newton, "
          f"{single['gmres_iterations']} GMRES, {single['events']['PCApply_n']} PC applications (the same counts as "
          f"in double: {single_same}); max|w| series within {single_deviation:.1e} of double's", flush=True)
    single.update(counts_as_double=single_same, max_w_series_vs_double=single_deviation)
    last = _counting()
    runs = []
    for N in COUNT_SIZES:
        c = serial_counts(N, last)
        runs.append(c)
        print(f"measured serial default {N}^2 to t = 10 ({c['linear_solver']}, order {c['max_order']}, rtol "
              f"{c['rtol']:g}): solve {c['solve_s']:.2f} s, {c['steps']} steps, {c['newton_iterations']} Newton, "
              f"{c['linear_iterations']} GMRES, {c['n_rhs']} RHS, {c['preconditioner_setups']} Jacobians, {c['lu']} "
              f"factorizations, {c['preconditioner_solves']} preconditioner applications; max|w|(10) "
              f"{c['max_w']['10']:.6e}", flush=True)
    lin_per_newton = engine[-1]["gmres_iterations"] / max(engine[-1]["newton_iterations"], 1)  # the engine's GMRES
    costs = []
    for n in CELLS_PER_RANK:
        for P in XF_RANKS:
            N = math.isqrt(P * n)
            c = rank_costs(N, P, n, lin_per_newton)
            costs.append(c)
            print(f"measured per rank, {n} cells of {N}^2 on {P} ranks (slab {c['slab'][0]} x {c['slab'][1]}, "
                  f"{c['wave_numbers']} wave numbers of {3 * N} unknowns): RHS {c['rhs_s'][0] * 1e3:.3f} ms, "
                  f"Jacobian {c['jac_s'][0] * 1e3:.2f} ms, x-average {c['xavg_s'][0] * 1e3:.3f} ms, factors "
                  f"{c['factor_s'][0] * 1e3:.2f} ms, band solves {c['band_solve_s'][0] * 1e3:.3f} ms, FFTs and packing "
                  f"{c['fft_s'][0] * 1e3:.3f} ms, Gram-Schmidt {c['gram_schmidt_s'][0] * 1e3:.3f} ms (min of repeats)",
                  flush=True)
    transposes = measure_alltoall(CELLS_PER_RANK)
    for t in transposes:
        print(f"measured on 2 ranks here: transpose of {t['bytes_per_rank']} bytes per rank "
              f"{t['alltoall_s'][0] * 1e6:.1f} us (median {t['alltoall_s'][1] * 1e6:.1f}), exact: "
              f"{t['transposed_exactly']}; allreduce {t['allreduce_s'][0] * 1e6:.1f} us", flush=True)
    return {"uptime": os.popen("uptime").read().strip(), "engine": engine, "engine_2_ranks": two,
            "engine_2_ranks_single_precision_transposes": single,
            "serial": runs, "rank_costs": costs, "transposes_2_ranks": transposes, "reductions_2_ranks": reductions}


def alltoall_time(bytes_per_rank: float, P: int, latency: float, beta: float) -> tuple[float, str]:
    """An all-to-all where each of P ranks sends `bytes_per_rank` in all (P blocks, one its own):
    the cheaper of pairwise exchange, (P - 1) alpha + (P - 1)/P m beta, and Bruck's algorithm,
    log2(P) alpha + (m/2) log2(P) beta (Thakur, Rabenseifner and Gropp, "Optimization of collective
    communication operations in MPICH", Int. J. High Perform. Comput. Appl. 19 (2005) 49-66,
    section 4), the choice MPI libraries make by message size."""
    if P == 1:
        return 0.0, ""
    pairwise = (P - 1) * latency + (P - 1) / P * bytes_per_rank * beta
    bruck = math.ceil(math.log2(P)) * latency + bytes_per_rank / 2 * math.log2(P) * beta
    return (pairwise, "pairwise") if pairwise <= bruck else (bruck, "Bruck")


def xfourier_model(kept: dict, latency: float, node_bandwidth: float, ranks_per_node: int,
                   transpose_bytes: float = TRANSPOSE_BYTES_PER_CELL) -> list:
    """Per step on P ranks at n cells each: counts per step at the grid N = sqrt(P n) (power laws in N
    fitted to the PETSc engine's runs on 1 rank), compute from the per-rank costs measured at that
    block, and the communication under the network assumed, a transpose moving `transpose_bytes`
    per cell. Returns the rows of the table and the fitted counts."""
    runs = engine_counts(kept["engine"])
    sides = [r["N"] for r in runs]
    per_step = {}
    for name in ("steps", "newton", "gmres", "rhs", "jacobians", "factorizations", "applications"):
        values = [r[name] for r in runs]
        per_step[name] = (values[-1], sides[-1], power_law(sides, values))

    def at(name, N):
        value, N0, q = per_step[name]
        return value * (N / N0) ** q

    beta = ranks_per_node / node_bandwidth  # s per byte per rank when every rank of a node sends at once
    measured_step = {r["N"]: r["step_s"] for r in runs}  # the PETSc engine's CPU per step, 1 rank
    red = kept["reductions_2_ranks"]
    rows = []
    for n in sorted({c["cells_per_rank"] for c in kept["rank_costs"]}):
        base = None
        for c in sorted((c for c in kept["rank_costs"] if c["cells_per_rank"] == n), key=lambda c: c["P"]):
            N, P = c["N"], c["P"]
            steps, rhs, jac, lu, apps, gmres, newton = (at(k, N) for k in (
                "steps", "rhs", "jacobians", "factorizations", "applications", "gmres", "newton"))
            compute = (rhs * c["rhs_s"][0] + jac * (c["jac_s"][0] + c["xavg_s"][0]) + lu * c["factor_s"][0]
                       + apps * (c["fft_s"][0] + c["band_solve_s"][0]) + gmres * c["gram_schmidt_s"][0])
            if P == 1:
                halo = transposes = reductions = gather = 0.0
                algorithm = ""
            else:
                halo = rhs * 2 * (latency + 3 * 8 * N * beta)  # one ghost row of 3 fields to each of 2 neighbours
                one, algorithm = alltoall_time(transpose_bytes * n, P, latency, beta)
                transposes = apps * 2 * one
                # GMRES's, the steps' (inside TSStep: SNES norms, TS's error norm, the mass correction), and
                # the engine's state check after each step (one max-reduction, outside TSStep)
                count = red["krylov_reductions_per_application"] * apps + red["other_reductions_per_step"] + 1
                reductions = count * 2 * latency * math.log2(P)  # recursive doubling of a few numbers
                gather = jac * (math.ceil(math.log2(P)) * latency + c["averages_bytes"] * beta)
            step = compute + halo + transposes + reductions + gather
            if base is None:  # P = 1: the engine's measured time per step over the kernels' (the rest of a step)
                base, overhead = step, measured_step.get(N, step) / step
            calibrated = compute * overhead + halo + transposes + reductions + gather
            base_calibrated = base * overhead
            rows.append({"cells_per_rank": n, "P": P, "N": N, "steps": steps, "newton_per_step": newton,
                         "gmres_per_step": gmres, "applications_per_step": apps, "compute_s": compute, "halo_s": halo,
                         "transposes_s": transposes, "alltoall": algorithm, "reductions_s": reductions,
                         "averages_gather_s": gather, "step_s": step, "efficiency": base / step,
                         "compute_share": compute / step, "run_s": steps * step, "overhead_factor": overhead,
                         "step_calibrated_s": calibrated, "efficiency_calibrated": base_calibrated / calibrated})
    return rows, per_step


def bandwidth_needed(kept: dict, latency: float, ranks_per_node: int, transpose_bytes: float, target: float = 0.5,
                     P: int = 256) -> dict:
    """The bandwidth per rank (bytes/s) at which the model's calibrated weak efficiency at P ranks
    reaches `target`, per cells per rank (bisection in the node's bandwidth, the rest of the
    network as assumed); None where even a network without bandwidth cost does not reach it."""
    out = {}
    for n in sorted({c["cells_per_rank"] for c in kept["rank_costs"]}):
        def efficiency(bandwidth):
            rows, _ = xfourier_model(kept, latency, bandwidth * ranks_per_node, ranks_per_node, transpose_bytes)
            return next(r["efficiency_calibrated"] for r in rows if r["cells_per_rank"] == n and r["P"] == P)

        low, high = 1e6, 1e15  # bytes/s per rank
        if efficiency(high) < target:
            out[n] = None
            continue
        for _ in range(60):
            middle = math.sqrt(low * high)
            low, high = (middle, high) if efficiency(middle) < target else (low, middle)
        out[n] = high
    return out


def xfourier_main(args) -> None:
    """The model of the x-Fourier preconditioner on PETSc over P = 64, 256, 1024 ranks at 64^2,
    128^2 and 256^2 cells per rank (the grid sqrt(P n) a side, split in z-slabs of all x).

    Measured here, in this process unless said:

    * what a step needs, from the PETSc engine itself (its defaults: TS BDF, SNES Newton, GMRES to
      1e-2 preconditioned by the x-Fourier shell), iCIDR bump2d 32^2 .. 512^2 to t = 10, each a
      whole ``mpiexec -n 1`` process (:func:`engine_run`): steps, Newton and GMRES iterations,
      right-hand sides (TSFunctionEval: the matrix-free products of ``-snes_mf_operator``
      included), Jacobians, the shell's banded factorizations and its applications (PCApply) per
      step, each fitted as a power of the grid side and extrapolated to the grid of P ranks; and
      the engine's CPU time per step of the integration (from the end of its set-up to its last
      step: CPU, not wall, because the machine is shared). The same counts on 2 ranks at 128^2
      (they are checked to be 1 rank's), and, from PETSc's log of that run, the reductions per
      preconditioner application in the Krylov solves and per step besides. CVODE's counters of
      the serial default at 32^2 .. 256^2 are measured beside them, for comparison only;
    * per rank, with one thread, at the block a rank of P holds (:func:`rank_costs`): the
      right-hand side, the Jacobian rows and their x-average, the band factors and solves of its
      wave numbers, the FFTs with the packing around the transposes, GMRES's Gram-Schmidt;
    * on 2 ranks of this machine (``mpiexec -n 2``, PETSc's scatter): a transpose of the size a
      rank sends (24 bytes per cell), and an allreduce; and the engine on 2 ranks at 128^2 with
      the transposes' values rounded to single precision (:func:`_single_precision_transposes`,
      a what-if: its counts and max|w| against double's), for ``--transpose-bytes-per-cell 12``.

    Modelled (ASSUMPTIONS named in the JSON and the table's notes): the network of
    :data:`NET_LATENCY`, :data:`NODE_BANDWIDTH` and :data:`RANKS_PER_NODE` (every rank of a node
    sends at once through the node's link: the per-rank bandwidth is the node's divided by its
    ranks, traffic within a node counted at that rate too); the all-to-all by
    :func:`alltoall_time`; a halo exchange per right-hand side (one ghost row to each of 2
    neighbours); an allreduce of a few numbers 2 alpha log2(P), one more per step for the engine's
    state check; the x-averages gathered once per Jacobian; no overlap, no imbalance beyond the
    wave numbers' (ceil((N/2)/P) per rank). The compute of a step is the kernels' sum; the PETSc
    engine's measured CPU time per step on 1 rank is more than that sum (the Python callbacks,
    PETSc's vector work and copies, the Jacobian's assembly around the kernels: the ratio is
    printed), so a second efficiency takes the kernels' sum times that ratio, measured at each
    block size on 1 rank ("calibrated": the work around the kernels assumed to grow as they do)."""
    if args.measured:
        kept = json.loads(pathlib.Path(args.measured).read_text())
        kept = kept.get("measured", kept)
        if "engine" not in kept:
            print(f"--measured: {args.measured} holds no runs of the PETSc engine (a measurement of this benchmark "
                  f"before they were made); measure again without --measured", file=sys.stderr)
            sys.exit(2)
        print(f"measured: {args.measured} ({kept['uptime']})")
    else:
        print(f"uptime: {os.popen('uptime').read().strip()}", flush=True)
        kept = measure_xfourier(tuple(args.sizes))
        kept["uptime_end"] = os.popen("uptime").read().strip()
    rows, per_step = xfourier_model(kept, args.latency, args.node_bandwidth, args.ranks_per_node,
                                    args.transpose_bytes_per_cell)
    engine = {r["N"]: r for r in kept["engine"]}
    serial = {r["N"]: r for r in kept["serial"]}
    check = []
    for row in rows:  # the model's compute on 1 rank against the engine's run it is calibrated by
        r = engine.get(row["N"]) if row["P"] == 1 else None
        if r is None:
            continue
        c = next(c for c in kept["rank_costs"] if c["P"] == 1 and c["N"] == row["N"])
        e, steps = r["events"], r["steps"]
        jacobians = max(r["n_jac"], 1)
        kernels = {"rhs": c["rhs_s"][0], "jacobian": c["jac_s"][0],
                   "pc_setup_per_jacobian": c["xavg_s"][0] + c["factor_s"][0] * r["factorizations"] / jacobians,
                   "application": c["fft_s"][0] + c["band_solve_s"][0]}
        logged = {"rhs": e["TSFunctionEval_s"] / max(e["TSFunctionEval_n"], 1),
                  "jacobian": e["TSJacobianEval_s"] / jacobians, "pc_setup_per_jacobian": e["PCSetUp_s"] / jacobians,
                  "application": e["PCApply_s"] / max(e["PCApply_n"], 1)}
        s_row = serial.get(row["N"])
        check.append({"N": row["N"], "modelled_step_s": row["compute_s"], "measured_step_s": r["integration_cpu_s"] / steps,
                      "serial_default_step_s": None if s_row is None else s_row["cpu_s"] / s_row["steps"],
                      "serial_default_steps": None if s_row is None else s_row["steps"], "engine_steps": steps,
                      "kernel_s": kernels, "petsc_event_s": logged})
    print(f"\nx-Fourier on PETSc, weak scaling; the PETSc engine's counts per step ~ N^q fitted over "
          f"{min(engine)}^2..{max(engine)}^2: "
          + ", ".join(f"{k} {v[0]:.2f} at {v[1]}^2, q = {v[2]:.2f}" for k, v in per_step.items()))
    for c in check:
        serial_note = "" if c["serial_default_step_s"] is None else (
            f"; the serial default's (CVODE) run CPU {c['serial_default_step_s'] * 1e3:.2f} ms per step of "
            f"{c['serial_default_steps']}")
        print(f"1 rank at {c['N']}^2: modelled compute per step {c['modelled_step_s'] * 1e3:.2f} ms, the PETSc "
              f"engine's integration CPU per step measured {c['measured_step_s'] * 1e3:.2f} ms of {c['engine_steps']} steps "
              f"(kernels / measured {c['modelled_step_s'] / c['measured_step_s']:.2f}){serial_note}; per call, "
              f"kernels against PETSc's events: "
              + ", ".join(f"{k} {c['kernel_s'][k] * 1e3:.3f} / {c['petsc_event_s'][k] * 1e3:.3f} ms"
                          for k in c["kernel_s"]))
    print(f"network assumed: latency {args.latency * 1e6:g} us, {args.node_bandwidth / 1e9:g} GB/s per node of "
          f"{args.ranks_per_node} ranks ({args.node_bandwidth / args.ranks_per_node / 1e9:.3f} GB/s per rank); "
          f"a transpose moves {args.transpose_bytes_per_cell:g} bytes per cell")
    print("| cells per rank | ranks P | grid | steps | GMRES/step | PC apps/step | compute/step | halo/step | "
          "transposes/step | reductions/step | step | weak efficiency | compute share | step, calibrated | "
          "weak efficiency, calibrated |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        side = math.isqrt(r["cells_per_rank"])
        print(f"| {side}^2 | {r['P']} | {r['N']}^2 | {r['steps']:.0f} | {r['gmres_per_step']:.1f} | "
              f"{r['applications_per_step']:.1f} | "
              f"{r['compute_s'] * 1e3:.1f} ms | {r['halo_s'] * 1e3:.2f} ms | {r['transposes_s'] * 1e3:.2f} ms"
              f"{(' (' + r['alltoall'] + ')') if r['alltoall'] else ''} | {r['reductions_s'] * 1e3:.2f} ms | "
              f"{r['step_s'] * 1e3:.1f} ms | {r['efficiency']:.2f} | {r['compute_share']:.2f} | "
              f"{r['step_calibrated_s'] * 1e3:.1f} ms | {r['efficiency_calibrated']:.2f} |")
    needed = {}
    for size in sorted({args.transpose_bytes_per_cell, TRANSPOSE_BYTES_PER_CELL, TRANSPOSE_BYTES_PER_CELL / 2},
                       reverse=True):
        needed[f"{size:g}"] = bandwidth_needed(kept, args.latency, args.ranks_per_node, size)
        print(f"bandwidth per rank for a calibrated weak efficiency of 0.5 at 256 ranks, {size:g} bytes per cell a "
              f"transpose, latency {args.latency * 1e6:g} us: " + ", ".join(
                  f"{math.isqrt(n)}^2 cells per rank " + ("not reached at any bandwidth" if b is None else
                                                          f"{b / 1e9:.2f} GB/s ({b * args.ranks_per_node / 1e9:.0f} "
                                                          f"GB/s a node of {args.ranks_per_node})")
                  for n, b in needed[f"{size:g}"].items()))
    assumptions = {"latency_s": args.latency, "node_bandwidth_bytes_per_s": args.node_bandwidth,
                   "ranks_per_node": args.ranks_per_node, "transpose_bytes_per_cell": args.transpose_bytes_per_cell}
    if args.measured and not args.json:  # the model again: the kept measurement's file stays as it was
        return
    write_json(args.json or str(ROOT / "data" / "benchmarks" / "petsc_weak_model.json"),
               {"measured": kept, "assumptions": assumptions, "model": rows, "model_check_1_rank": check,
                "bandwidth_per_rank_for_half_at_256": {size: {str(n): b for n, b in by_n.items()}
                                                       for size, by_n in needed.items()},
                "counts_per_step": {k: {"value": v[0], "at_N": v[1], "exponent": v[2]} for k, v in per_step.items()}})


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--engine-child":
        engine_child(int(sys.argv[2]), float(sys.argv[3]), sys.argv[4])
        return
    if "--pc" not in sys.argv or "xfourier" in sys.argv:
        ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
        ap.add_argument("--pc", choices=["xfourier"], default="xfourier")
        ap.add_argument("--latency", type=float, default=NET_LATENCY, help="s per MPI message (assumed)")
        ap.add_argument("--node-bandwidth", type=float, default=NODE_BANDWIDTH, help="bytes/s per node (assumed)")
        ap.add_argument("--ranks-per-node", type=int, default=RANKS_PER_NODE)
        ap.add_argument("--json", default=None, help="default: data/benchmarks/petsc_weak_model.json (with "
                        "--measured: none unless given)")
        ap.add_argument("--measured", default=None, help="model from a kept JSON of this benchmark (no runs)")
        ap.add_argument("--transpose-bytes-per-cell", type=float, default=TRANSPOSE_BYTES_PER_CELL,
                        help="bytes a transpose moves per cell (the engine's: 3 fields' complex doubles, 24; "
                             "12 models them sent in single precision)")
        ap.add_argument("--sizes", type=int, nargs="+", default=list(ENGINE_SIZES),
                        help="the grids of the PETSc engine's 1-rank runs (counts per step, time per step); "
                             "they must hold the cells per rank modelled (64, 128, 256)")
        xfourier_main(ap.parse_args())
        return
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
