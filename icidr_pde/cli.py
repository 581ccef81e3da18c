"""Command line: ``icidr-pde {demo,run,tstar,verify,stability,dem,figures}``."""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time

from .discretizations import DISCRETIZATIONS
from .integrator import JACOBIAN_MODES, METHODS
from .presets import PRESETS
from .rheology import RHEOLOGIES
from .scenes import SCENES, scene_parameters

# subcommands provided by their own modules: (module, function)
_PLUGINS = [
    ("icidr_pde.studies.cli", "add_parser"),
    ("stability.cli", "add_verify_parser"),
    ("stability.cli", "add_stability_parser"),
    ("icidr_pde.dem.cli", "add_parser"),
    ("icidr_pde.figures", "add_parser"),
    ("icidr_pde.law_cli", "add_parser"),
]


def discretization_options() -> dict[str, tuple]:
    """Every option of every registered discretization -> the union of its valid values."""
    out: dict[str, tuple] = {}
    for cls in DISCRETIZATIONS.values():
        for key, valid in cls.options.items():
            out[key] = tuple(dict.fromkeys(out.get(key, ()) + tuple(valid)))
    return out


def rheology_name(text):
    """argparse type: a registered rheology or a law file ``*.py`` (checked when the law is built)."""
    if text in RHEOLOGIES or text.endswith(".py"):
        return text
    raise argparse.ArgumentTypeError(f"must be one of {sorted(RHEOLOGIES)} or a law file *.py, got {text!r}")


def positive_int(text):
    """argparse type: an integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def add_run_parser(subparsers):
    p = subparsers.add_parser("run", help="run one scene with one rheology")
    p.add_argument("--rheology", type=rheology_name, default="icidr", metavar="NAME|FILE",
                   help=f"one of {', '.join(sorted(RHEOLOGIES))}, or a law file *.py (see `law check`)")
    p.add_argument("--scene", choices=sorted(SCENES), default="shear")
    p.add_argument("--accuracy", choices=sorted(PRESETS), default="standard",
                   help="preset for discretization, N, method and tolerances (measured: see README)")
    p.add_argument("--discretization", choices=sorted(DISCRETIZATIONS), default=None,
                   help="default: from --accuracy")
    p.add_argument("--N", type=positive_int, default=None,
                   help="grid cells (fd) or collocation points (cheb) (default: from --accuracy)")
    p.add_argument("--Nx", type=positive_int, default=None, help="cells along x (2-D scenes; default: Nz)")
    p.add_argument("--Nz", type=positive_int, default=None, help="cells along z (2-D scenes; default: Nx or --N)")
    p.add_argument("--t-end", type=float, default=10.0)
    p.add_argument("--times", nargs="+", default=None, help="snapshot times (labels of the JSON max_w)")
    p.add_argument("--rtol", type=float, default=None, help="default: from --accuracy")
    p.add_argument("--atol", type=float, default=None, help="default: from --accuracy")
    p.add_argument("--method", choices=METHODS, default=None, help="default: from --accuracy")
    p.add_argument("--jacobian", choices=JACOBIAN_MODES, default=None,
                   help="default: the method's best (analytic for BDF/Radau/CVODE, banded-fd for LSODA)")
    for key, valid in discretization_options().items():
        p.add_argument(f"--{key}", choices=valid, default=None,
                       help=f"option of {', '.join(n for n, c in DISCRETIZATIONS.items() if key in c.options)} "
                            f"(default {valid[0]})")
    for name, help_text in scene_parameters().items():
        p.add_argument(f"--{name}", type=float, default=None, help=f"scene parameter: {help_text}")
    p.add_argument("--json", default=None, help="write the result summary here")
    p.add_argument("--plot", default=None, help="write a PNG of profiles and max|w|(t)")
    p.add_argument("--save", default=None, help="write the snapshots to this HDF5 file")
    p.add_argument("--movie", default=None, help="write a movie of the run (.mp4, or .gif)")
    p.add_argument("--frame-dt", type=float, default=None,
                   help="simulated time between movie frames, independent of --times "
                        "(default: 40 log-spaced frames up to t_end/200, then every t_end/200)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_run)


def cmd_run(args) -> int:
    from .api import run

    scene_params = {k: getattr(args, k) for k in scene_parameters() if getattr(args, k) is not None}
    N = args.N
    if args.Nx is not None or args.Nz is not None:
        nz = args.Nz or args.N or args.Nx
        N = (args.Nx or nz, nz)
    result = run(
        args.rheology, args.scene, N, args.t_end, args.times,
        accuracy=args.accuracy, discretization=args.discretization, method=args.method, rtol=args.rtol,
        atol=args.atol, jacobian=args.jacobian, advection=args.advection,
        progress=not args.no_progress, save=args.save, movie=args.movie, frame_dt=args.frame_dt,
        **scene_params,
    )
    print(result)
    print(json.dumps({k: v for k, v in result.to_dict().items()
                      if k in ("blew_up", "t_star", "reason", "max_w", "mass_drift", "wall_s")}, indent=1))
    if args.json:
        result.save_json(args.json)
    if args.plot:
        from .plotting import plot_result

        if result.measures is not None:
            from .studies2d import plot_fields as plot_result
        plot_result(result, args.plot)
        print(f"plot written to {args.plot}")
    if args.movie:
        print(f"movie written to {args.movie}")
    return 0


def add_demo_parser(subparsers):
    p = subparsers.add_parser(
        "demo", help="the paper's headline in under a minute: mu(I) blows up on refinement, iCIDR converges")
    p.add_argument("--plot", default="icidr_demo.png")
    p.add_argument("--coarse", type=positive_int, default=47)
    p.add_argument("--fine", type=positive_int, default=201)
    p.set_defaults(func=cmd_demo)


def cmd_demo(args) -> int:
    from .api import run
    from .plotting import demo_figure

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
    demo_figure(runs[("mui", args.coarse)], runs[("mui", args.fine)],
                runs[("icidr", args.coarse)], runs[("icidr", args.fine)], args.plot)
    fine = runs[("mui", args.fine)]
    print(f"\nmu(I),Phi(I): N = {args.coarse} "
          f"{'fails' if runs[('mui', args.coarse)].blew_up else 'decays to steady shear'}; "
          f"N = {args.fine} " + (f"fails at t* = {fine.t_star:.4g}" if fine.blew_up else "does not fail"))
    a, b = runs[("icidr", args.coarse)], runs[("icidr", args.fine)]
    print(f"iCIDR: max|w| at t = 1: N = {args.coarse}: {a.max_w_at_times()['1']:.3e}, "
          f"N = {args.fine}: {b.max_w_at_times()['1']:.3e} (no failure: {not (a.blew_up or b.blew_up)})")
    print(f"figure written to {args.plot} ({time.perf_counter() - start:.0f} s)")
    return 0


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="icidr-pde", description="mu(I),Phi(I) vs iCIDR in the 1-D shear cell (Schaeffer et al. 2019)")
    subparsers = parser.add_subparsers(dest="command", required=True)
    add_demo_parser(subparsers)
    add_run_parser(subparsers)
    for module_name, function in _PLUGINS:
        getattr(importlib.import_module(module_name), function)(subparsers)
    return parser


def main(argv=None) -> int:
    parser = make_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as err:
        print(f"icidr-pde: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
