"""``icidr-pde dem steady|transient``: LAMMPS DEM validation (appendix C, figs 1 and 8).

Wiring (lead): in icidr_pde/cli.py ``from icidr_pde.dem.cli import add_parser;
add_parser(subparsers)``; each sub-subcommand sets ``func(args) -> int``.
Standalone: ``python -m icidr_pde.dem steady ...``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..cli import positive_int as _pos_int


def _common(p):
    p.add_argument("--repeats", type=_pos_int, default=10, help="independent runs per phi0 (10)")
    p.add_argument("--particles", type=_pos_int, default=1000, help="disks per cell, multiple of 5 (1000)")
    p.add_argument("--seed", type=int, default=1, help="base seed (1)")
    p.add_argument("--jobs", type=_pos_int, default=2, help="parallel LAMMPS processes (2)")
    p.add_argument("--cache", default="data/dem/cache", help="per-run cache directory")
    p.add_argument("--t-shear", type=float, default=30.0, help="shearing before averaging (30)")
    p.add_argument("--t-avg", type=float, default=100.0, help="averaging window (100)")
    p.add_argument("--dt-fraction", type=float, default=1 / 50,
                   help="time step / shortest contact time (0.02)")
    p.add_argument("--no-progress", action="store_true")


def add_parser(subparsers):
    """Add ``dem`` with ``steady`` and ``transient`` to an argparse subparsers object."""
    dem = subparsers.add_parser("dem", help="LAMMPS DEM validation (appendix C, figs 1 and 8)",
                                description=__doc__)
    sub = dem.add_subparsers(dest="dem_command", required=True)
    st = sub.add_parser("steady", help="steady mu(I), Phi(I) sweep, fits of (2.10)-(2.11), fig 1")
    st.add_argument("--phi0", type=float, nargs="+", default=[0.76, 0.77, 0.78, 0.79, 0.80])
    _common(st)
    st.add_argument("--json", default="data/dem/steady.json")
    st.add_argument("--fig", default="docs/fig1_dem.png")
    st.set_defaults(func=cmd_steady)
    tr = sub.add_parser("transient", help="(5.7) transient ensemble vs iCIDR, fig 8")
    _common(tr)
    tr.add_argument("--steady-json", default="data/dem/steady.json",
                    help="steady study JSON holding our fitted parameters")
    tr.add_argument("--N", type=_pos_int, default=201, help="continuum grid cells (201)")
    tr.add_argument("--json", default="data/dem/transient.json")
    tr.add_argument("--npz", default="data/dem/transient_ensemble.npz")
    tr.add_argument("--fig", default="docs/fig8_dem.png")
    tr.add_argument("--drop-fluctuations", action="store_true",
                    help="replace particle velocities by (5.7) exactly (use a separate --cache)")
    tr.set_defaults(func=cmd_transient)
    return dem


def _setup(args):
    from .params import DEMParams
    from .runs import Protocol

    return DEMParams(n_particles=args.particles, dt_fraction=args.dt_fraction), \
        Protocol(t_shear=args.t_shear, t_avg=args.t_avg)


def cmd_steady(args) -> int:
    from . import plots
    from .steady import run_steady_study

    params, protocol = _setup(args)
    s = run_steady_study(args.phi0, repeats=args.repeats, base_seed=args.seed, jobs=args.jobs,
                         cache_dir=args.cache, protocol=protocol, params=params,
                         json_path=args.json, progress=not args.no_progress)
    if "fit" in s and args.fig:
        Path(args.fig).parent.mkdir(parents=True, exist_ok=True)
        plots.fig1(s, args.fig)
    for pt in s["points"]:
        print(f"phi0={pt['phi0']:.3f}  I={pt['I']:.4f}+-{pt['I_std']:.4f}  "
              f"mu={pt['mu']:.4f}+-{pt['mu_std']:.4f}  ({pt['repeats']} runs)")
    if "fit" in s:
        for k, v in s["fit"].items():
            sd = s["fit_std"][k]
            sd = "undetermined" if sd is None else f"{sd:.4f}"
            print(f"{k:6s} = {v:.4f} +- {sd}   (Table 1: {s['table1'][k]})")
    print(f"wrote {args.json}" + (f", {args.fig}" if args.fig and 'fit' in s else ""))
    return 0


def cmd_transient(args) -> int:
    from icidr_pde.rheology import Material

    from . import plots, transient

    params, protocol = _setup(args)
    path = Path(args.steady_json)
    if not path.exists():
        raise SystemExit(f"--steady-json {path} not found: run `dem steady` first")
    fit = json.loads(path.read_text())["fit"]
    from .runs import SineIC

    sine_ic = SineIC(keep_fluctuations=not args.drop_fluctuations)
    if args.drop_fluctuations and Path(args.cache).resolve() == Path("data/dem/cache").resolve():
        raise ValueError("`--cache` must differ from data/dem/cache with --drop-fluctuations")
    results = transient.transient_results(args.repeats, args.particles, args.seed, args.jobs,
                                          args.cache, protocol, params, not args.no_progress, sine_ic)
    ens = transient.ensemble(results)
    edges = transient_edges(ens)
    c1 = transient.continuum(ens["times"], Material(), N=args.N, edges=edges)
    c2 = transient.continuum(ens["times"], Material(**fit), N=args.N, edges=edges)
    summ = transient.summarize(ens, c1, c2, fit)
    transient.write_json(summ, args.json)
    if args.npz:
        transient.save_ensemble({**ens, **{f"icidr_table1_{f}": c1[f] for f in transient.FIELDS},
                                 **{f"icidr_fitted_{f}": c2[f] for f in transient.FIELDS}}, args.npz)
    e1, e2 = transient.errors(ens, c1), transient.errors(ens, c2)
    if args.fig:
        Path(args.fig).parent.mkdir(parents=True, exist_ok=True)
        plots.fig8(ens, c1, c2, e1, e2, args.fig)
    for name, key in (("Table 1", "rel_error_table1_summary"), ("fitted", "rel_error_fitted_summary")):
        b = summ[key]
        print(f"{name:8s}: E max {100 * b['max']:.2f} %  mean {100 * b['mean']:.2f} %  | "
              + "  ".join(f"{f}: max {100 * b[f + '_max']:.2f} % mean {100 * b[f + '_mean']:.2f} %"
                          f" (floor {100 * b[f + '_floor_mean']:.2f} %)" for f in transient.FIELDS))
    print(f"wrote {args.json}, {args.npz}, {args.fig}")
    return 0


def transient_edges(ens):
    import numpy as np

    z = np.asarray(ens["z"])
    h = z[1] - z[0]
    return np.concatenate([z - h / 2, [z[-1] + h / 2]])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m icidr_pde.dem")
    sub = parser.add_subparsers(dest="command", required=True)
    add_parser(sub)
    args = parser.parse_args(["dem", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.func(args)
    except ValueError as exc:
        parser.error(str(exc))
        return 2
