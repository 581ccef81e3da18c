"""Memory of a thin 2-D cell's line preconditioner per unknown (icidr_pde.engines.linear.line.LINE_BYTES).

iCIDR bump2d on Nx x Nz cells with L such that hx = 60 hz (a thin cell, as 4096 x 256 at
L = 120000): the line preconditioner of :mod:`icidr_pde.engines.sundae` is built and set up
once, as CVODE does at its first step. Printed per unknown: the peak that tracemalloc sees
during the set-up (numpy and scipy.sparse: the analytic Jacobian, its restriction to the line
pattern, I - gamma J_line), what is still held after it, SuperLU's factors (C memory that
tracemalloc does not see, from their entries: 8 bytes a value and 4 an index) and the line
pattern; their sum is what icidr_pde.engines.linear.line.LINE_BYTES must cover.

    nice -n 10 python benchmarks/line_memory.py [--sizes 256x32 512x64 1024x64]
"""

import argparse
import tracemalloc

import numpy as np

from icidr_pde.case import build_case
from icidr_pde.engines.linear.line import LINE_BYTES, line_preconditioner
from icidr_pde.engines.stiff import conserved


def measure(nx: int, nz: int, H: float = 30.0, aspect: float = 60.0) -> dict:
    """Bytes per unknown of one set-up of the line preconditioner on nx x nz cells (hx = aspect hz)."""
    case = build_case("icidr", "bump2d", "fv2d", (nx, nz), scene_params={"H": H, "L": aspect * H * nx / nz})
    pde, state = case.pde, case.state
    pattern = pde.line_pattern(state)
    if pattern is None:
        raise SystemExit(f"{nx} x {nz} is not a thin cell")
    jac = pde.make_jacobian(state)
    weights, anchor = conserved(pde, state, None)
    y = state.data.ravel().copy()
    jac(0.0, y)  # compiled before the measurement
    tracemalloc.start()
    precond = line_preconditioner(jac, pattern, weights, anchor)
    precond.setupfn(0.0, y, None, False, np.zeros(1, dtype=np.int32), 0.01)
    held, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    saved = next(c.cell_contents for c in precond.setupfn.__closure__ if isinstance(c.cell_contents, dict))
    lu = saved["lu"]
    n = y.size
    return {"cells": f"{nx} x {nz}", "unknowns": n, "setup_peak": peak / n, "held": held / n,
            "factors": 12 * (lu.L.nnz + lu.U.nnz) / n,
            "pattern": (pattern.data.nbytes + pattern.indices.nbytes + pattern.indptr.nbytes) / n}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["256x32", "512x64", "1024x64"])
    args = parser.parse_args()
    print(f"bytes per unknown (LINE_BYTES = {LINE_BYTES:g})")
    for size in args.sizes:
        nx, nz = (int(v) for v in size.split("x"))
        m = measure(nx, nz)
        total = m["setup_peak"] + m["factors"] + m["pattern"]
        print(f"{m['cells']:>11}: set-up peak {m['setup_peak']:.0f}, held after it {m['held']:.0f}, SuperLU's "
              f"factors {m['factors']:.0f}, pattern {m['pattern']:.0f}; sum {total:.0f}")


if __name__ == "__main__":
    main()
