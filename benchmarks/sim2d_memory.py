"""Where the serial 2-D default's memory goes: bytes per cell by stage, and the whole process's peak.

iCIDR bump2d on N^2 cells with the 2-D default on the py-pde path (CVODE, GMRES preconditioned by
the x-Fourier inverse: ``--engine pde``, the CLI's defaults otherwise). For each N, in child processes:

* **whole process**: the peak resident memory (wait4's ru_maxrss) of ``icidr-pde run`` to --t-end,
  and of the same run on the --floor grid; per cell: their difference over the difference of cells
  (Python, numpy, py-pde and the compiled kernels are the floor);
* **stages** (one run in a child with tracemalloc on: numpy and scipy.sparse, not C memory), per cell:
  the arrays held when CVODE starts (case, py-pde state, the problem's work arrays); CVODE's and
  GMRES's vectors (C memory: SUNDIALS' own count, ``CVodeGetWorkSpace`` + ``CVodeGetLinWorkSpace``,
  and scikit-sundae's state vector); the x-Fourier factors (the banded LU of the Nx / 2 + 1 wave
  numbers, complex); the x-average's peak while it is computed by blocks
  (:mod:`icidr_pde.engines.linear.x_average`) and, for comparison, the peak of averaging the whole
  analytic sparse Jacobian at y0 (how it was computed before); the traced peak of the whole run
  (everything numpy holds at once: with the RHS temporaries, the Jacobian-vector product's
  vectors, the Result's kept states);

and the model's estimate (:data:`icidr_pde.discretizations.grid_size.PLANE2D` with the x-Fourier
solver's memory) beside the measured peak.

    nice -n 10 python benchmarks/sim2d_memory.py [--sizes 256 512] [--t-end 1] [--floor 32]
"""

import argparse
import json
import os
import pathlib
import subprocess
import sys
import tempfile

from provenance import write_json

STAGE_CHILD = r'''
import ctypes, json, sys, tracemalloc
n, t_end, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
import numpy as np
from icidr_pde import run
from icidr_pde.engines import sundae
from icidr_pde.engines.linear import x_average as xa, xfourier_inverse as xi

rec = {"x_average_peak": 0}
call, init, engine_init = xa.XAverage.__call__, xi.XFourierPreconditioner.__init__, sundae.CvodeEngine.__init__

def average(self, t, y):
    held = tracemalloc.get_traced_memory()[0]
    tracemalloc.reset_peak()
    result = call(self, t, y)
    rec["x_average_peak"] = max(rec["x_average_peak"], tracemalloc.get_traced_memory()[1] - held)
    return result

def factors(self, *args, **kwargs):
    init(self, *args, **kwargs)
    f = self.factors
    rec["factors"] = f.lu.nbytes + f.reciprocal.nbytes + f.pivots.nbytes

def engine(self, *args, **kwargs):
    rec["held_at_cvode"] = tracemalloc.get_traced_memory()[0]
    engine_init(self, *args, **kwargs)
    lib, mem = self.counters.lib, self.counters.mem
    words = {}
    for name in ("CVodeGetWorkSpace", "CVodeGetLinWorkSpace"):
        rw, iw = ctypes.c_long(), ctypes.c_long()
        function = getattr(lib, name)
        function.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_long), ctypes.POINTER(ctypes.c_long)]
        function(mem, ctypes.byref(rw), ctypes.byref(iw))
        words[name] = (rw.value, iw.value)
    rec["cvode_words"] = words
    rec["cvode"] = 8 * sum(rw + iw for rw, iw in words.values()) + 8 * len(self.problem.y0)  # + scikit-sundae's yy

xa.XAverage.__call__, xi.XFourierPreconditioner.__init__, sundae.CvodeEngine.__init__ = average, factors, engine
tracemalloc.start()
result = run("icidr", "bump2d", (n, n), t_end, method="CVODE", rtol=1e-5, atol=1e-8, engine="pde")
rec["traced_peak"] = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
rec["n_steps"], rec["linear_solver"] = result.n_steps, result.settings["linear_solver"]

# the whole analytic Jacobian averaged at y0, as before the x-average by blocks
from icidr_pde.case import build_case
case = build_case("icidr", "bump2d", "fv2d", (n, n))
jac, y0 = case.pde.make_jacobian(case.state), case.state.data.ravel().copy()
xi.x_average(jac(0.0, y0), case.state.data.shape)  # compiled
tracemalloc.start()
J = jac(0.0, y0)
rec["whole_jacobian"] = J.data.nbytes + J.indices.nbytes + J.indptr.nbytes
xi.x_average(J, case.state.data.shape)
rec["whole_jacobian_peak"] = tracemalloc.get_traced_memory()[1]
tracemalloc.stop()
json.dump(rec, open(out, "w"))
'''


def whole_process(n: int, t_end: float, options=()) -> dict:
    """Peak RSS (bytes) and steps of one CLI run of the default (with `options`) on n^2 cells to t_end."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "out.json"
        cmd = [sys.executable, "-m", "icidr_pde.cli", "run", "--scene", "bump2d", "--rheology", "icidr",
               "--Nx", str(n), "--Nz", str(n), "--t-end", str(t_end), "--no-progress", "--engine", "pde",
               "--json", str(out), *options]
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        _, status, usage = os.wait4(proc.pid, 0)
        stderr = proc.stderr.read().decode()
        proc.stderr.close()
        if os.waitstatus_to_exitcode(status) != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{stderr}")
        result = json.loads(out.read_text())
    return {"max_rss": usage.ru_maxrss * 1024, "n_steps": result["n_steps"]}


def stages(n: int, t_end: float) -> dict:
    """The stage figures (bytes) of one traced run on n^2 cells (module notes)."""
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "stages.json"
        proc = subprocess.run([sys.executable, "-c", STAGE_CHILD, str(n), str(t_end), str(out)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(proc.stderr)
        return json.loads(out.read_text())


def estimate(n: int) -> float:
    """The model's bytes for the default on n^2 cells: the scheme's and the x-Fourier solver's."""
    from icidr_pde.discretizations.grid_size import PLANE2D
    from icidr_pde.engines.linear.xfourier import XFourierGmres

    return PLANE2D.memory_estimate(n * n) + XFourierGmres().memory(3 * n * n, "CVODE", "fourier").bytes


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--floor", type=int, default=32, help="the grid whose peak counts as the process's floor")
    parser.add_argument("--krylov", action="store_true",
                        help="also the whole process of GMRES without a preconditioner (--jacobian krylov): the "
                             "scheme's own estimate, PLANE2D")
    parser.add_argument("--json", default="data/benchmarks/sim2d_memory.json")
    args = parser.parse_args()
    floor = whole_process(args.floor, args.t_end)
    print(f"floor ({args.floor}^2): peak RSS {floor['max_rss'] / 1e6:.0f} MB")
    rows, floor_krylov = [], None
    for n in args.sizes:
        cells = n * n
        whole, stage = whole_process(n, args.t_end), stages(n, args.t_end)
        per_cell = (whole["max_rss"] - floor["max_rss"]) / (cells - args.floor**2)
        row = {"N": n, "t_end": args.t_end, "n_steps": whole["n_steps"], "max_rss": whole["max_rss"],
               "bytes_per_cell": per_cell, "estimate": estimate(n),
               **{k: v for k, v in stage.items() if k not in ("n_steps",)}}
        if args.krylov:
            krylov = whole_process(n, args.t_end, ("--jacobian", "krylov"))
            floor_krylov = floor_krylov or whole_process(args.floor, args.t_end, ("--jacobian", "krylov"))
            row["krylov_max_rss"] = krylov["max_rss"]
            row["krylov_bytes_per_cell"] = (krylov["max_rss"] - floor_krylov["max_rss"]) / (cells - args.floor**2)
            print(f"{n}^2, GMRES alone: peak RSS {krylov['max_rss'] / 1e6:.0f} MB "
                  f"({row['krylov_bytes_per_cell']:.0f} B a cell above its floor)")
        rows.append(row)
        print(f"{n}^2: peak RSS {whole['max_rss'] / 1e6:.0f} MB ({per_cell:.0f} B a cell above the floor), "
              f"model {row['estimate'] / 1e6:.0f} MB; {whole['n_steps']} steps")
        for label, key in (("arrays held when CVODE starts", "held_at_cvode"), ("CVODE's and GMRES's vectors (C)", "cvode"),
                           ("x-Fourier factors", "factors"), ("x-average's peak, by blocks", "x_average_peak"),
                           ("the whole Jacobian (CSC)", "whole_jacobian"),
                           ("averaging the whole Jacobian: peak", "whole_jacobian_peak"),
                           ("traced peak of the run (numpy)", "traced_peak")):
            print(f"    {label:<40} {stage[key] / cells:7.0f} B a cell  ({stage[key] / 2**20:6.0f} MiB)")
    write_json(args.json, {"floor": {"N": args.floor, **floor}, "rows": rows})


if __name__ == "__main__":
    main()
