"""``icidr-pde dem steady|transient|pool|audit``: the LAMMPS DEM validation (appendix C, figs 1 and 8).

Outputs go to ``--out`` (default: the current directory), never over the
committed results; the per-run cache to the user cache (``--cache``).  The
committed results (``data/dem``, shipped with the package) are read through
the package from any directory.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .argtypes import int_at_least, positive_int as _pos_int
from ..outputs import check_outputs, writable_folder, write_json
from .cluster import add_cluster_options, client_of
from .common import DefaultsFormatter


def _fraction(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number in (0, 0.2]; got {text!r}") from None
    if not 0 < v <= 0.2:
        raise argparse.ArgumentTypeError(f"must be a number in (0, 0.2]; got {text!r}")
    return v


_seed = int_at_least(0)


def _needs_lammps(command):
    """`command` with a missing LAMMPS reported as bad input (one line, exit 2) and Ctrl-C as one
    line (exit 130), not a traceback."""
    def run(args) -> int:
        try:
            return command(args)
        except KeyboardInterrupt:  # Ctrl-C: one line, the status of the other commands, no traceback
            print(f"icidr-pde: dem {args.dem_command} interrupted; runs already finished are kept in the per-run "
                  "cache (--cache) and reused by the same command", file=sys.stderr)
            return 130
        except ImportError as err:
            if "LAMMPS" not in str(err):
                raise
            raise ValueError(f"`dem {args.dem_command}` runs LAMMPS, which is not installed: {err}") from None

    run.__name__ = command.__name__
    return run


def _common(p, what):
    p.add_argument("--repeats", type=_pos_int, default=10, help="independent runs per phi0")
    p.add_argument("--particles", type=_pos_int, default=1000, help="disks per cell, multiple of 5")
    p.add_argument("--H", type=float, default=30.0, help="cell height (Lees-Edwards direction), d")
    p.add_argument("--k-n", type=float, default=1.0e4,
                   help="normal stiffness; eta_n is scaled by sqrt(k_n/1e4) to keep e = 0.9")
    p.add_argument("--seed", type=_seed, default=1, help="base seed (>= 0)")
    p.add_argument("--cache", default=None,
                   help="per-run cache directory (default: $ICIDR_PDE_CACHE or ~/.cache/icidr-pde/dem)")
    p.add_argument("--t-shear", type=float, default=30.0, help="shearing before averaging / before the perturbation")
    p.add_argument("--dt-fraction", type=_fraction, default=1 / 50, help="time step / shortest contact time")
    p.add_argument("--out", default=".", help=f"directory for the {what} (created if missing)")
    p.add_argument("--no-progress", action="store_true", help="no progress output")


def add_parser(subparsers):
    """Add ``dem`` with ``steady``, ``transient`` and ``audit`` to an argparse subparsers object."""
    dem = subparsers.add_parser("dem", help="LAMMPS DEM validation (appendix C, figs 1 and 8)",
                                description=__doc__,
                                formatter_class=DefaultsFormatter)
    sub = dem.add_subparsers(dest="dem_command", required=True)
    fmt = DefaultsFormatter
    st = sub.add_parser("steady", help="steady mu(I), Phi(I) sweep, fits of (2.10)-(2.11), fig 1",
                        description="Steady Lees-Edwards shear at each phi0; writes steady.json and fig1_dem.png.",
                        formatter_class=fmt)
    st.add_argument("--phi0", type=float, nargs="+", default=[0.76, 0.77, 0.78, 0.79, 0.80],
                    help="mean packing fractions")
    _common(st, "JSON summary and figure")
    st.add_argument("--t-avg", type=float, default=100.0, help="averaging window")
    add_cluster_options(st, "the LAMMPS runs")
    st.add_argument("--json", default=None, help="summary path (default: OUT/steady.json)")
    st.add_argument("--fig", default=None, help="figure path (default: OUT/fig1_dem.png; '' for none)")
    st.set_defaults(func=_needs_lammps(cmd_steady))

    tr = sub.add_parser("transient", help="(5.7) transient ensemble vs iCIDR, fig 8",
                        description="Ensemble of (5.7) transients from independent steady states, "
                                    "compared with iCIDR (Table 1 and our fit); writes transient.json, "
                                    "transient_ensemble.npz and fig8_dem.png.",
                        formatter_class=fmt)
    _common(tr, "JSON summary, ensemble npz and figure")
    tr.add_argument("--steady-json", default=None,
                    help="steady study JSON holding our fitted parameters (default: the committed one)")
    tr.add_argument("--fluctuations", choices=("keep", "drop", "local"), default="keep",
                    help="particle velocity fluctuations when imposing (5.7): keep them, drop them "
                         "(zero granular temperature), or scale them to the local strain rate")
    tr.add_argument("--drop-fluctuations", action="store_true", help="same as --fluctuations drop")
    tr.add_argument("--preparation", choices=("minimize", "rescale"), default="minimize",
                    help="overlap removal: FIRE minimisation or appendix C's kinetic-energy rescaling")
    tr.add_argument("--transient-dt-fraction", type=_fraction, default=None,
                    help="time step of the transient / contact time (default: --dt-fraction)")
    tr.add_argument("--bin-height", type=float, default=2.0, help="coarse-graining bin height (divides H)")
    tr.add_argument("--u-definition", choices=("slab_mass", "area_times_mass", "centre"), default="slab_mass",
                    help="bin velocity: mass of the slab part of each disk, area x disk mass, or disk centres")
    tr.add_argument("--u-frame", choices=("offset", "layers", "lab"), default="offset",
                    help="frame of u: remove the streaming offset, the z = 0 layer's velocity, or none")
    tr.add_argument("--t-end", type=float, default=20.0, help="duration of the transient")
    tr.add_argument("--N", type=_pos_int, default=201, help="continuum grid cells")
    tr.add_argument("--json", default=None, help="summary path (default: OUT/transient.json)")
    tr.add_argument("--npz", default=None, help="ensemble path (default: OUT/transient_ensemble.npz; '' for none)")
    tr.add_argument("--fig", default=None, help="figure path (default: OUT/fig8_dem.png; '' for none)")
    add_cluster_options(tr, "the ensemble's members")
    tr.set_defaults(func=_needs_lammps(cmd_transient))

    po = sub.add_parser("pool", help="fig 1 pooled over k_n, H and N: run the pool (resumable) or summarise it",
                        description="Runs the pooled fig-1 configurations (one LAMMPS process, each run cached "
                                    "as it finishes), fits them with the committed reference sweep "
                                    "(steady_pool.json, fig1_dem.png), or prints the tables of docs/dem.md from "
                                    "OUT/steady_pool.json.", formatter_class=fmt)
    po.add_argument("action", choices=("run", "summary", "tables"))
    po.add_argument("configs", nargs="*", help="configurations (default: all, in the default order)")
    po.add_argument("--cache", default=None, help="cache directory (default: the user cache)")
    po.add_argument("--out", default=".", help="directory of steady_pool.json and fig1_dem.png (summary writes "
                                               "them, tables reads steady_pool.json)")
    po.set_defaults(func=_needs_lammps(cmd_pool))

    au = sub.add_parser("audit", help="protocol audit of fig 8(d): run factor ensembles or write the report",
                        description="Runs the factor ensembles of the protocol audit (resumable from the cache) "
                                    "or summarises them (audit.json, audit.npz, fig8_audit.png).",
                        formatter_class=fmt)
    au.add_argument("action", choices=("run", "report"))
    au.add_argument("factors", nargs="*", help="factors to run (run): baseline, drop_fluctuations, ...")
    au.add_argument("--repeats", type=_pos_int, default=10, help="members per factor (run)")
    au.add_argument("--first", type=int_at_least(0), default=0, help="index of the first member (run)")
    au.add_argument("--cache", default=None, help="cache directory (default: the user cache)")
    au.add_argument("--out", default=".", help="directory for the report files")
    au.add_argument("--no-progress", action="store_true", help="no progress output")
    add_cluster_options(au, "the members (run)")
    au.set_defaults(func=_needs_lammps(cmd_audit))
    return dem


# ------------------------------------------------------------------ helpers
def _writable_dir(path) -> Path:
    """Create ``path`` if needed and check it can be written, before any run."""
    return writable_folder("--out", path)


def _output(arg, out: Path, default_name, option: str = "output"):
    """Explicit path, '' for none, or OUT/default_name; checked before any run."""
    if arg == "":
        return None
    path = Path(arg) if arg is not None else out / default_name
    if arg is not None:
        _writable_dir(path.parent)
    check_outputs({option: path})
    return path


def _params(args):
    from ..dem.params import DEMParams

    eta = 4.2 * (args.k_n / 1.0e4) ** 0.5
    return DEMParams(n_particles=args.particles, H=args.H, k_n=args.k_n, eta_n=eta,
                     dt_fraction=args.dt_fraction)


def _cache(args, *, writes: bool = True) -> Path:
    """The per-run cache folder, checked before any run: one a command `writes` to is made and
    probed as every output folder is; one it only reads must be a folder where it exists."""
    from ..dem.cache import default_cache_dir

    path = Path(args.cache) if args.cache else default_cache_dir()
    if writes:
        return writable_folder("--cache", path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"`--cache` must be a directory; got the file {str(path)!r}")
    return path


# ------------------------------------------------------------------ commands
def cmd_steady(args) -> int:
    from ..dem import plots
    from ..dem.runs import Protocol
    from ..dem.steady import run_steady_study

    out = _writable_dir(args.out)
    json_path = _output(args.json, out, "steady.json", "--json")
    fig_path = _output(args.fig, out, "fig1_dem.png", "--fig")
    check_outputs({"--json": json_path, "--fig": fig_path})  # not one file
    cache_dir = _cache(args)
    params = _params(args)
    protocol = Protocol(t_shear=args.t_shear, t_avg=args.t_avg)
    with client_of(args, dashboard=not args.no_progress) as client:
        s = run_steady_study(args.phi0, repeats=args.repeats, base_seed=args.seed, jobs=args.jobs, client=client,
                             cache_dir=cache_dir, protocol=protocol, params=params, json_path=json_path,
                             progress=not args.no_progress)
    if "fit" in s and fig_path:
        plots.fig1(s, fig_path)
    for pt in s["points"]:
        print(f"phi0={pt['phi0']:.3f}  I={pt['I']:.4f}+-{pt['I_std']:.4f}  "
              f"mu={pt['mu']:.4f}+-{pt['mu_std']:.4f}  ({pt['repeats']} runs)")
    if "fit" in s:
        for k, v in s["fit"].items():
            sd = s["fit_std"][k]
            sd = "undetermined" if sd is None else f"{sd:.4f}"
            print(f"{k:6s} = {v:.4f} +- {sd}   (Table 1: {s['table1'][k]})")
    print("wrote " + ", ".join(str(p) for p in (json_path, fig_path if "fit" in s else None) if p))
    return 0


def cmd_transient(args) -> int:
    from icidr_pde.rheology import Material

    from ..dem import analysis, ensemble, plots, transient
    from ..dem.paths import committed

    out = _writable_dir(args.out)
    json_path = _output(args.json, out, "transient.json", "--json")
    npz_path = _output(args.npz, out, "transient_ensemble.npz", "--npz")
    fig_path = _output(args.fig, out, "fig8_dem.png", "--fig")
    check_outputs({"--json": json_path, "--npz": npz_path, "--fig": fig_path})  # not one file
    cache_dir = _cache(args)
    steady = Path(args.steady_json) if args.steady_json else committed("steady.json")
    if not steady.is_file():
        raise ValueError(f"`--steady-json` {str(steady)!r} not found: run `icidr-pde dem steady` first")
    params = _params(args)  # validates N, H, k_n, dt before anything else
    hb = args.bin_height
    if not (hb >= 1 and float(hb).is_integer() and abs(args.H / hb - round(args.H / hb)) < 1e-9):
        raise ValueError(f"`--bin-height` must be a whole number of d dividing H = {args.H}; got {args.bin_height}")
    fit = json.loads(steady.read_text())["fit"]
    fluct = "drop" if args.drop_fluctuations else args.fluctuations
    base = ensemble.BaseState(phi0=0.78, params=params, preparation=args.preparation, t_shear=args.t_shear)
    pert = ensemble.Perturbation(fluctuations=fluct, t_end=args.t_end,
                                 dt_fraction=args.transient_dt_fraction)
    with client_of(args, dashboard=not args.no_progress) as client:
        members = ensemble.run_ensemble(base, ensemble.seeds(args.repeats, args.seed, base.phi0), [pert],
                                        cache_dir, jobs=args.jobs, client=client, progress=not args.no_progress)
    results = [member[0] for member in members]
    S = analysis.stack(results, args.bin_height, args.u_definition, args.u_frame)
    ens = {"times": S["times"], "z": S["z"], "repeats": len(results), "phi0": base.phi0, "H": args.H,
           "a": pert.a, "b": pert.b}
    for f in transient.FIELDS:
        ens[f"{f}_mean"] = S[f].mean(0)
        ens[f"{f}_std"] = S[f].std(0, ddof=1) if len(results) > 1 else 0 * S[f][0]
    ens["max_w"] = abs(ens["w_mean"]).max(axis=1)
    edges = transient_edges(ens)
    c1 = transient.continuum(ens["times"], Material(), N=args.N, edges=edges, H=args.H)
    c2 = transient.continuum(ens["times"], Material(**fit), N=args.N, edges=edges, H=args.H)
    summ = transient.summarize(ens, c1, c2, fit)
    summ["protocol"] = {"fluctuations": fluct, "preparation": args.preparation, "t_shear": args.t_shear,
                        "dt_fraction": args.dt_fraction, "transient_dt_fraction": args.transient_dt_fraction,
                        "bin_height": args.bin_height, "u_definition": args.u_definition,
                        "u_frame": args.u_frame, "n_particles": args.particles, "H": args.H, "k_n": args.k_n}
    if json_path:
        write_json(summ, json_path)
    if npz_path:
        transient.save_ensemble({**ens, **{f"icidr_table1_{f}": c1[f] for f in transient.FIELDS},
                                 **{f"icidr_fitted_{f}": c2[f] for f in transient.FIELDS}}, npz_path)
    e1, e2 = transient.errors(ens, c1), transient.errors(ens, c2)
    if fig_path:
        plots.fig8(ens, c1, c2, e1, e2, fig_path)
    for name, key in (("Table 1", "rel_error_table1_summary"), ("fitted", "rel_error_fitted_summary")):
        b = summ[key]
        print(f"{name:8s}: E max {100 * b['max']:.2f} %  mean {100 * b['mean']:.2f} %  | "
              + "  ".join(f"{f}: max {100 * b[f + '_max']:.2f} % (floor {100 * b[f + '_floor_mean']:.2f} %)"
                          for f in transient.FIELDS))
    pk = summ["secondary_max_w_peak"]
    print(f"secondary max|w|: DEM {pk['dem']['max_w']:.4f} at t = {pk['dem']['t']:.1f}, "
          f"iCIDR (Table 1) {pk['table1']['max_w']:.4f} at t = {pk['table1']['t']:.1f}")
    print("wrote " + ", ".join(str(p) for p in (json_path, npz_path, fig_path) if p))
    return 0


def cmd_pool(args) -> int:
    from ..dem import pool

    unknown = [c for c in args.configs if c not in pool.CONFIGS]
    if unknown:
        raise ValueError(f"`configs` must be among {list(pool.CONFIGS)}; got {unknown}")
    names = args.configs or None
    if args.action == "run":
        pool.run(_cache(args), names)
        return 0
    if args.action == "tables":
        path = Path(args.out) / "steady_pool.json"
        try:
            print(pool.markdown(json.loads(path.read_text())))
        except (OSError, ValueError) as err:
            raise ValueError(f"`--out` {str(args.out)!r}: cannot read {str(path)!r} as the pool's summary "
                             f"(`dem pool summary` writes it): {getattr(err, 'strerror', None) or err}") from None
        return 0
    from ..dem.plots import fig1_pool

    cache_dir = _cache(args, writes=False)
    out = _writable_dir(args.out)
    s = pool.summary(cache_dir, names)
    write_json(s, out / "steady_pool.json")
    fig1_pool(s, out / "fig1_dem.png")
    print(pool.markdown(s))
    print(f"wrote {out / 'steady_pool.json'}, {out / 'fig1_dem.png'}")
    return 0


def cmd_audit(args) -> int:
    from ..dem import audit

    cache_dir = _cache(args, writes=args.action == "run")
    if args.action == "run":
        unknown = [f for f in args.factors if f not in audit.FACTORS]
        if not args.factors or unknown:
            raise ValueError(f"`factors` must be among {sorted(audit.FACTORS)}; got {args.factors}")
        with client_of(args, dashboard=not args.no_progress) as client:
            runs = audit.run_factors(args.factors, args.repeats, cache_dir, first=args.first, jobs=args.jobs,
                                     client=client, progress=not args.no_progress)
        for name, results in runs.items():
            print(f"{name}: members {args.first + 1}..{args.first + len(results)} in {cache_dir}")
        return 0
    from ..dem.audit_report import make_report

    out = _writable_dir(args.out)
    make_report(cache_dir, out / "audit.json", out / "audit.npz", out / "fig8_audit.png")
    print(f"wrote {out / 'audit.json'}, {out / 'audit.npz'}, {out / 'fig8_audit.png'}")
    return 0


def transient_edges(ens):
    import numpy as np

    z = np.asarray(ens["z"])
    h = z[1] - z[0]
    return np.concatenate([z - h / 2, [z[-1] + h / 2]])


def cmd(args) -> int:
    """Run the ``dem`` subcommand parsed."""
    return args.func(args)
