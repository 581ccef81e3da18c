"""Persistent stiff solver vs py-pde's stock `scipy` solver under tracker interrupts.

py-pde's ScipySolver calls solve_ivp afresh between interrupts (BDF restarts at order 1
with a fresh Jacobian); StiffSolver keeps one integrator. Same PDE, same numba RHS, same
tolerances, a tracker every 0.1 time units; accuracy against a tight-tolerance run.

    python benchmarks/persistent_solver.py [--scene sine --N 201 --t-end 20]
"""

import argparse
import time

import numpy as np
from pde.solvers import Controller, ScipySolver
from pde.trackers.trackers import CallbackTracker

from icidr_pde import StiffSolver, build_case


def integrate(solver, state, t_end, every):
    tracker = CallbackTracker(lambda s, t: None, interrupts=every)
    start = time.perf_counter()
    final = Controller(solver, t_range=t_end, tracker=[tracker]).run(state)
    return time.perf_counter() - start, final.data.copy()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--scene", default="sine")
    parser.add_argument("--N", type=int, default=201)
    parser.add_argument("--t-end", type=float, default=20.0)
    parser.add_argument("--every", type=float, default=0.1)
    parser.add_argument("--rtol", type=float, default=1e-6)
    args = parser.parse_args()
    case = build_case("icidr", args.scene, "fd", args.N)
    pde = case.pde

    def fresh():
        return case.state.copy()

    atol = args.rtol * 1e-3
    pde.make_pde_rhs(fresh(), backend="numba")  # compile once, outside the timings
    _, ref = integrate(StiffSolver(pde, rtol=1e-11, atol=1e-13), fresh(), args.t_end, args.t_end)
    rows = []
    ours = StiffSolver(pde, rtol=args.rtol, atol=atol)
    t_ours, y_ours = integrate(ours, fresh(), args.t_end, args.every)
    rows.append(("StiffSolver (persistent BDF, analytic J)", t_ours, ours.stats.n_steps, ours.stats.n_rhs, y_ours))
    stock = ScipySolver(pde, backend="numba", method="BDF", rtol=args.rtol, atol=atol,
                        jac_sparsity=pde.jacobian_sparsity(fresh()))
    t_stock, y_stock = integrate(stock, fresh(), args.t_end, args.every)
    rows.append(("py-pde ScipySolver (BDF, sparse FD J)", t_stock, None, stock.info["steps"], y_stock))
    stock_j = ScipySolver(pde, backend="numba", method="BDF", rtol=args.rtol, atol=atol,
                          jac=pde.make_jacobian(fresh()))
    t_stock_j, y_stock_j = integrate(stock_j, fresh(), args.t_end, args.every)
    rows.append(("py-pde ScipySolver (BDF, analytic J)", t_stock_j, None, stock_j.info["steps"], y_stock_j))
    print(f"iCIDR scene {args.scene}, N = {args.N}, t_end = {args.t_end}, tracker every {args.every}, "
          f"rtol = {args.rtol}, atol = {atol:g}")
    print(f"{'solver':44s} {'wall [s]':>9s} {'ratio':>7s} {'steps':>7s} {'rhs evals':>10s} {'rel err w':>10s}")
    for name, wall, steps, nrhs, y in rows:
        err = np.max(np.abs(y[2] - ref[2])) / max(np.max(np.abs(ref[2])), 1e-300)
        print(f"{name:44s} {wall:9.3f} {wall / t_ours:7.2f} {steps if steps is not None else '-':>7} "
              f"{nrhs:>10} {err:10.2e}")


if __name__ == "__main__":
    main()
