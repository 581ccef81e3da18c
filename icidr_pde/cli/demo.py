"""``icidr-pde demo``: the paper's headline in under a minute (mu(I) blows up on refinement, iCIDR
converges), figs 3(a), 4(a) and 6 in one figure."""

from __future__ import annotations

import time

from .argtypes import positive_int
from .common import figure_path, write_outputs

__all__ = ["add_parser", "cmd"]


def add_parser(subparsers):
    """Add ``demo`` to the ``icidr-pde`` command."""
    p = subparsers.add_parser(
        "demo", help="the paper's headline in under a minute: mu(I) blows up on refinement, iCIDR converges",
        description="Run scene shear (3.16) with mu(I),Phi(I) and iCIDR on a coarse and a fine grid "
                    "(finite volumes, BDF rtol 1e-6, atol 1e-9, as the paper's ode15s) and draw figs "
                    "3(a), 4(a) and 6 in one figure.")
    p.add_argument("--plot", default="icidr_demo.png", help="figure file (PNG if no suffix)")
    p.add_argument("--coarse", type=positive_int, default=47, help="coarse grid: cells N (well resolved)")
    p.add_argument("--fine", type=positive_int, default=201, help="fine grid: cells N (mu(I) fails here)")
    return p


def cmd(args) -> int:
    from ..api import run
    from ..plotting import demo_figure

    args.plot = figure_path("--plot", args.plot)
    start = time.perf_counter()
    runs = {}
    jobs = [
        ("mui", args.coarse, 10.0, ["0", "0.5", "1", "2", "5", "10"]),
        ("mui", args.fine, 10.0, ["0", "0.002", "0.005", "0.01"]),
        ("icidr", args.coarse, 10.0, ["0", "0.5", "1", "2", "5", "10"]),
        ("icidr", args.fine, 10.0, ["0", "0.5", "1", "2", "5", "10"]),
    ]
    for rheology, n, t_end, times in jobs:
        print(f"running {rheology:5s} N = {n:3d} (scene shear, IC (3.16)) ...", flush=True)
        # ode15s-like settings, as in the paper
        result = run(rheology, "shear", n, t_end, times, method="BDF", rtol=1e-6, atol=1e-9)
        runs[(rheology, n)] = result
        print("   ", result)
    figure_args = (runs[("mui", args.coarse)], runs[("mui", args.fine)],
                   runs[("icidr", args.coarse)], runs[("icidr", args.fine)])
    status = write_outputs([("--plot", args.plot, lambda path: demo_figure(*figure_args, path))])
    fine = runs[("mui", args.fine)]
    print(f"\nmu(I),Phi(I): N = {args.coarse} "
          f"{'fails' if runs[('mui', args.coarse)].blew_up else 'decays to steady shear'}; "
          f"N = {args.fine} " + (f"fails at t* = {fine.t_star:.4g}" if fine.blew_up else "does not fail"))
    a, b = runs[("icidr", args.coarse)], runs[("icidr", args.fine)]
    print(f"iCIDR: max|w| at t = 1: N = {args.coarse}: {a.max_w_at_times()['1']:.3e}, "
          f"N = {args.fine}: {b.max_w_at_times()['1']:.3e} (no failure: {not (a.blew_up or b.blew_up)})")
    print(f"done in {time.perf_counter() - start:.0f} s")
    return status
