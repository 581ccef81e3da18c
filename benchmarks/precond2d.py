"""Preconditioners of CVODE's Newton matrix M = I - gamma J for the 2-D cell, against N.

J is the analytic sparse Jacobian (:meth:`ShearCell2DPDE.make_jacobian`) of iCIDR bump2d at
t = 0 on N^2 cells (``--time T``: at the state the default run reaches at t = T), gamma a typical BDF step coefficient (``--gamma``, default 0.05: the
steps of bump2d to t = 10 are 0.01-0.2). For each preconditioner: the set-up time (one
factorisation, CPU time of this process: wall times on a loaded machine mean little), its fill (nnz of the factors over nnz(M)), and GMRES(20) (scipy) on
M x = b (b random, fixed seed) to a relative residual 1e-6: iterations and solve time.

* SuperLU (scipy ``splu``) with the COLAMD and the minimum-degree (A^T + A) orderings;
* ILU (scipy ``spilu``, drop_tol 1e-4, fill_factor 10);
* the z-line block preconditioner: M restricted to the couplings within each x column
  (:meth:`ShearCell2DPDE.line_pattern` with the thin-cell threshold lifted), factored by
  SuperLU (Nx independent banded systems after the ordering);
* algebraic multigrid, one V-cycle per GMRES iteration (set-up: the hierarchy): pyamg's
  smoothed aggregation with its defaults on M (scalar: every unknown a node), its nodal form
  (the 3 fields of a cell one BSR block, constant fields as near-null space), and the one CVODE
  uses (``--jacobian amg``, :class:`icidr_pde.engines.linear.amg_hierarchy.AmgHierarchy`: nodal aggregation,
  unsmoothed prolongators, one block Gauss-Seidel sweep on the cells' 3 x 3 blocks before and
  after, compiled);
* the x-Fourier preconditioner (``--jacobian fourier``, :class:`icidr_pde.engines.linear.xfourier_inverse.XFourierPreconditioner`:
  the exact inverse of I - gamma A, A the x-average of J, by the FFT in x and banded LUs in z).

Only the z-line, the last AMG and the x-Fourier are wired into the integrator; ``--amg-only`` measures the
AMG rows alone (SuperLU's factors at 256^2 would take ~2 GB).

    nice -n 5 python benchmarks/precond2d.py [--sizes 64 128 256] [--amg-only] [--time 0.5]
"""

import argparse
import time

import numpy as np
from scipy import sparse
from scipy.sparse import linalg

import icidr_pde.cells.plane2d.core as plane2d_core
from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
from icidr_pde.cells.plane2d.scenes import Bump2DScene

from provenance import write_json


def newton_matrix(n: int, gamma: float, t: float = 0.0):
    pde = ShearCell2DPDE("icidr")
    grid = pde.make_grid((n, n), 30.0)
    scene = Bump2DScene()
    state = pde.make_state(grid, *scene.initial_condition(pde.nodes(grid)))
    if t > 0:
        from icidr_pde import run

        r = run("icidr", "bump2d", (n, n), t, [f"{t:g}"], series_times=[])
        state = pde.make_state(grid, r.phi[-1], r.u[-1], r.w[-1])
    J = pde.make_jacobian(state)(t, state.data.ravel())
    M = sparse.csc_matrix(sparse.identity(J.shape[0]) - gamma * J)
    plane2d_core.THIN_CELL = 0.0
    line = pde.line_pattern(state)
    plane2d_core.THIN_CELL = 10.0
    M_line = sparse.csc_matrix(M.multiply(line))
    return M, M_line


def gmres_with(M, apply, b):
    count = [0]

    def callback(_):
        count[0] += 1

    P = linalg.LinearOperator(M.shape, matvec=apply)
    start = time.process_time()
    x, info = linalg.gmres(M, b, M=P, rtol=1e-6, restart=20, maxiter=200, callback=callback,
                           callback_type="pr_norm")
    return {"iterations": count[0], "converged": info == 0, "solve_s": time.process_time() - start,
            "residual": float(np.linalg.norm(M @ x - b) / np.linalg.norm(b))}


def amg_rows(n: int, gamma: float, M, b) -> list[dict]:
    """One V-cycle of each multigrid hierarchy as the preconditioner; fill: operator complexity."""
    import pyamg

    from icidr_pde.engines.linear.amg_hierarchy import AmgHierarchy

    J = (sparse.identity(M.shape[0], format="csr") - M) / gamma
    fields, cells = 3, M.shape[0] // 3
    order = (np.arange(M.shape[0]) % fields) * cells + np.arange(M.shape[0]) // fields
    position = np.argsort(order)
    nodal = sparse.bsr_matrix(sparse.csr_matrix(M)[order][:, order], blocksize=(fields, fields))
    B = np.kron(np.ones((cells, 1)), np.eye(fields))
    rows = []
    for name, build in (("AMG SA scalar", lambda: pyamg.smoothed_aggregation_solver(sparse.csr_matrix(M))),
                        ("AMG SA nodal", lambda: pyamg.smoothed_aggregation_solver(nodal, B=B))):
        start = time.process_time()
        ml = build()
        setup = time.process_time() - start
        if name.endswith("nodal"):
            def apply(v, ml=ml):
                return ml.solve(np.asarray(v)[order], maxiter=1, tol=1e-30)[position]
        else:
            def apply(v, ml=ml):
                return ml.solve(v, maxiter=1, tol=1e-30)
        rows.append({"N": n, "preconditioner": name, "setup_s": setup, "fill": ml.operator_complexity(),
                     **gmres_with(M, apply, b)})
    start = time.process_time()
    h = AmgHierarchy(J, fields, gamma)
    setup = time.process_time() - start
    rows.append({"N": n, "preconditioner": "AMG as wired (--jacobian amg)", "setup_s": setup,
                 "fill": sum(h.level(level).count_nonzero() for level in range(len(h.sizes))) / M.nnz, **gmres_with(M, h.vcycle, b)})
    return rows + [fourier_row(n, gamma, J, M, b)]


def fourier_row(n: int, gamma: float, J, M, b) -> dict:
    """The x-Fourier preconditioner as wired; fill: its banded factors' entries over nnz(M)."""
    from icidr_pde.engines.linear.xfourier_inverse import XFourierPreconditioner

    start = time.process_time()
    P = XFourierPreconditioner(J, (3, n, n), gamma)
    setup = time.process_time() - start
    return {"N": n, "preconditioner": "x-Fourier as wired (--jacobian fourier)", "setup_s": setup,
            "fill": P.factors.lu.size / M.nnz, **gmres_with(M, P.solve, b)}


def measure(n: int, gamma: float, amg_only: bool = False, t: float = 0.0) -> list[dict]:
    M, M_line = newton_matrix(n, gamma, t)
    b = np.random.default_rng(1).standard_normal(M.shape[0])
    rows = [{"N": n, "preconditioner": "none", "setup_s": 0.0, "fill": 1.0, **gmres_with(M, lambda v: v, b)}]
    if amg_only:
        return rows + amg_rows(n, gamma, M, b)
    for name, factor in (("SuperLU COLAMD", lambda: linalg.splu(M, permc_spec="COLAMD")),
                         ("SuperLU MMD(A^T+A)", lambda: linalg.splu(M, permc_spec="MMD_AT_PLUS_A")),
                         ("ILU 1e-4", lambda: linalg.spilu(M, drop_tol=1e-4, fill_factor=10)),
                         ("z-line SuperLU", lambda: linalg.splu(M_line, permc_spec="COLAMD"))):
        start = time.process_time()
        lu = factor()
        setup = time.process_time() - start
        rows.append({"N": n, "preconditioner": name, "setup_s": setup, "fill": (lu.L.nnz + lu.U.nnz) / M.nnz,
                     **gmres_with(M, lu.solve, b)})
    return rows + amg_rows(n, gamma, M, b)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256])
    parser.add_argument("--gamma", type=float, default=0.05)
    parser.add_argument("--amg-only", action="store_true", help="no preconditioner, the AMG and x-Fourier rows only")
    parser.add_argument("--time", type=float, default=0.0, help="the Jacobian at the state of the run at this time")
    parser.add_argument("--json", default="data/benchmarks/precond2d.json")
    args = parser.parse_args()
    rows = []
    print("| grid | preconditioner | set-up [s] | fill | GMRES(20) iterations | solve [s] |")
    print("| --- | --- | --- | --- | --- | --- |")
    for n in args.sizes:
        for r in measure(n, args.gamma, args.amg_only, args.time):
            rows.append(r)
            iters = f"{r['iterations']}" + ("" if r["converged"] else " (not converged)")
            print(f"| {n}² | {r['preconditioner']} | {r['setup_s']:.3f} | {r['fill']:.1f} | {iters} | {r['solve_s']:.3f} |",
                  flush=True)
    write_json(args.json, {"gamma": args.gamma, "time": args.time, "rows": rows,
                           "command": f"python benchmarks/precond2d.py --sizes {' '.join(map(str, args.sizes))}"
                                      + (" --amg-only" if args.amg_only else "") + f" --time {args.time:g}"})


if __name__ == "__main__":
    main()
