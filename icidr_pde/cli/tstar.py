"""``icidr-pde tstar``: the failure-time sweep of fig 4(b) on the command line::

    icidr-pde tstar --rheology mui --scene shear --discretization cheb --N 21:201:2 \\
        --t-end 20 --json cheb.json --plot fig4b.png

The JSON (:func:`~icidr_pde.studies.failure_time.tstar_report`, docs/cli.md) holds, for each
discretization, the settings the runs used, t* by N (as a string; null where the run reached
t-end without failing) and the reason each N failed. ``--accuracy stated`` (the default) runs each
case with the least costly settings that meet the accuracy stated for a t*
(:data:`~icidr_pde.studies.failure_time.ACCURACY`: the native engine, CVODE; Chebyshev within 1e-3
of the converged t*, finite volumes within their scatter); ``--accuracy paper`` with scipy's BDF at
rtol 1e-6, atol 1e-9 (the path fig 4(b)'s committed data and the paper's t* are pinned on).
``--engine``, ``--method``, ``--rtol``, ``--atol`` given take the place of the accuracy's. Several discretizations at once
(``--discretization fd cheb``) are entries of the same document; ``--load label=file.json`` adds
saved sweeps to the plot. ``--rheology`` takes a registered law or a law file, as ``run`` does (each
worker process reads the file itself: a Python law file is run in each). Interrupted (Ctrl-C, SIGTERM), the
workers are stopped and the cases that finished are written (exit 130, 143).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys

from ..discretizations import DISCRETIZATIONS
from ..engines import JACOBIAN_MODES, METHODS
from ..engines.choose import REQUESTS
from ..engines.base import check_tolerances
from ..outputs import check_outputs, write_json
from ..rheology.law_files import is_file_law, load_law_file
from ..scenes import SCENES
from ..studies.parallel import StudyInterrupted
from ..studies.failure_time import (ACCURACY, BDF_ATOL, BDF_RTOL, parse_range, read_tstar_curves, sweep,
                                   threshold, tstar_mapping, tstar_report)
from ..times import check_t_end
from ..validation import integer, real
from .argtypes import add_rheology_option
from .cluster import add_cache_option, add_cluster_options, check_cache_option, client_of
from .common import EXIT_INTERRUPTED, PREFIX, check_engine, interrupt_signals

__all__ = ["add_parser", "cmd"]


def _load_spec(text: str) -> tuple[str, str]:
    if "=" in text:
        label, path = text.split("=", 1)
    else:
        path = text
        label = os.path.splitext(os.path.basename(path))[0]
    return label, path


def _load_curves(text: str) -> dict[str, dict]:
    """{label: {N: t*}} of one ``--load LABEL=FILE``: one curve, labelled LABEL, per
    discretization of the file (LABEL plus the discretization's name where there are several).
    A file that is missing, unreadable or not a ``tstar --json`` document (this version's or an
    earlier flat or per-discretization one) is bad input (ValueError naming the option and the file)."""
    label, path = _load_spec(text)
    try:
        with open(path) as fh:
            document = json.load(fh)
    except (OSError, ValueError) as err:
        reason = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
        raise ValueError(f"`--load` {text!r}: cannot read {path!r} as JSON ({reason})") from None
    try:
        found = read_tstar_curves(document)
    except ValueError as err:
        raise ValueError(f"`--load` {text!r}: {path!r} must be a `tstar --json` file: {err}") from None
    curves = {}
    for disc, curve in found.items():
        for n, t_star in curve.items():  # checked here, not found out by the plot after the sweep
            try:
                integer("N", int(n) if n.strip().lstrip("+-").isdigit() else n, 1)
                if t_star is not None:
                    real("t*", t_star, 0, low_open=False)
            except ValueError:
                raise ValueError(f"`--load` {text!r}: {path!r} must map each N (an integer >= 1) to t* (a finite "
                                 f"number >= 0, or null: no failure); got {n!r}: {json.dumps(t_star)}") from None
        curves[label if len(found) == 1 else f"{label} {disc}"] = curve
    return curves


def _described(accuracy: str, discretization: str) -> str:
    row = ACCURACY[accuracy][discretization]
    return f"{row['engine']} engine, {row['method']}, rtol {row['rtol']:g}, atol {row['atol']:g}"


def _settings_text(runs: dict) -> str:
    """'native CVODE, rtol 1e-07, atol 1e-10' of a discretization's runs (each setting shown once)."""
    used = sorted({(r.get("engine"), r.get("method"), r.get("rtol"), r.get("atol")) for r in runs.values()}, key=str)
    return "; ".join(f"{e} {m}, rtol {rt:g}, atol {at:g}" for e, m, rt, at in used if rt is not None)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``tstar`` subcommand to an argparse subparsers object."""
    p = subparsers.add_parser(
        "tstar", help="failure time t*(N) sweep (fig 4b)",
        description="Sweep N and record the failure time t* (null: no failure by --t-end). "
                    "Interrupted (Ctrl-C: exit 130, SIGTERM: 143), the cases that finished are written.")
    add_rheology_option(p, "mui")
    p.add_argument("--scene", choices=sorted(SCENES), default="shear", help="initial condition")
    p.add_argument("--discretization", nargs="+", choices=sorted(DISCRETIZATIONS), default=None,
                   help="one or both of fd and cheb (default: fd; a 2-D scene's own, fv2d)")
    p.add_argument("--N", default=None,
                   help="start:stop:step with stop included, e.g. 21:201:2 (default), "
                        "or a comma-separated list")
    p.add_argument("--t-end", type=float, default=20.0, help="a run that reaches it did not fail")
    p.add_argument("--accuracy", choices=sorted(ACCURACY), default="stated",
                   help="stated (default): the least costly settings meeting the stated accuracy of a t* "
                        f"(Chebyshev within 1e-3 of the converged t*: {_described('stated', 'cheb')}; finite "
                        f"volumes within their scatter: {_described('stated', 'fd')}; docs/chebyshev.md); "
                        f"paper: the paper's ({_described('paper', 'cheb')})")
    p.add_argument("--engine", choices=[r for r in REQUESTS if r in ("pde", "native", "petsc")], default=None,
                   help="default: the accuracy's; pde: scipy's or scikit-sundae's solver on the py-pde scheme "
                        "(the paper's settings); native: the compiled problem and CVODE (Chebyshev: GMRES with "
                        "the low-order band preconditioner; the stated settings); petsc: PETSc on a 2-D scene "
                        "(runs under mpiexec: docs/distributed.md)")
    p.add_argument("--method", choices=sorted(METHODS), default=None,
                   help="integrator (default: the accuracy's; a method of scipy's runs on --engine pde)")
    p.add_argument("--rtol", type=float, default=None, help="relative tolerance (default: the accuracy's)")
    p.add_argument("--atol", type=float, default=None, help="absolute tolerance (default: the accuracy's)")
    p.add_argument("--jacobian", choices=JACOBIAN_MODES, default=None,
                   help="default: the method's own (analytic for BDF and Radau)")
    p.add_argument("--backend", choices=["numpy", "numba"], default="numpy",
                   help="right-hand side backend (numpy: no compile time, default)")
    add_cluster_options(p, "the cases", jobs=2)
    add_cache_option(p, "case")
    p.add_argument("--json", default=None,
                   help="write t*(N), the reason of each failure and the settings of the runs here")
    p.add_argument("--plot", default=None, help="write the t*(N) plot (fig 4b) here")
    p.add_argument("--load", action="append", default=[], metavar="LABEL=FILE",
                   help="add a saved `tstar --json` file to the plot (repeatable); "
                        "without --N nothing is run")
    p.add_argument("--no-progress", action="store_true")
    return p


def cmd(args) -> int:
    check_engine(args.engine)
    check_outputs({"--json": args.json, "--plot": args.plot})
    curves: dict[str, dict] = {}
    for spec in args.load:
        curves.update(_load_curves(spec))
    interrupted = None
    if args.N is None and args.load:
        results = {}
    else:
        Ns = parse_range(args.N or "21:201:2")
        if args.engine in ("native", "petsc") and args.method not in (None, "CVODE"):
            raise ValueError(f"`--method` must be CVODE with `--engine {args.engine}`; got {args.method!r}")
        check_tolerances(BDF_RTOL if args.rtol is None else args.rtol,
                         BDF_ATOL if args.atol is None else args.atol)  # those given
        check_t_end(args.t_end)
        check_cache_option(args)
        if is_file_law(args.rheology):  # read here, before any run: a file that cannot be used is bad input
            load_law_file(args.rheology)
        with interrupt_signals() as signals:
            try:
                with client_of(args, dashboard=not args.no_progress) as client:
                    discretizations = args.discretization or [getattr(SCENES[args.scene], "discretization", "fd")]
                    results = sweep(Ns, tuple(dict.fromkeys(discretizations)), jobs=args.jobs,
                                    progress=not args.no_progress, client=client, cache=args.cache,
                                    accuracy=args.accuracy, rheology=args.rheology, scene=args.scene,
                                    t_end=args.t_end, engine=args.engine, method=args.method, rtol=args.rtol,
                                    atol=args.atol, jacobian=args.jacobian, backend=args.backend)
            except StudyInterrupted as stop:  # the workers are stopped; what finished is written
                results, interrupted = stop.done, signals.received or signal.SIGINT
            except KeyboardInterrupt:  # before the first case started
                print(f"{PREFIX} interrupted before the sweep started; nothing written", file=sys.stderr)
                return EXIT_INTERRUPTED[signals.received or signal.SIGINT]
    if interrupted is not None:
        finished = sum(len(r) for r in results.values())
        print(f"{PREFIX} interrupted after {finished} of {len(Ns) * len(results)} cases; writing those that "
              "finished", file=sys.stderr)
        results = {d: r for d, r in results.items() if r}
    mappings = {d: tstar_mapping(r) for d, r in results.items()}
    for disc, mapping in mappings.items():
        curves[disc] = mapping
        failed = [(int(n), t) for n, t in mapping.items() if t is not None]
        thr = threshold(mapping)
        used = {(r.get("engine"), r.get("rtol"), r.get("atol")) for r in results[disc].values()}
        print(f"{disc}: " + "; ".join(f"engine {e}, rtol {rt:g}, atol {at:g}" for e, rt, at in sorted(used, key=str)
                                      if rt is not None))
        print(f"{disc}: {len(failed)}/{len(mapping)} runs failed; "
              f"every N >= {thr} fails" if thr is not None else
              f"{disc}: {len(failed)}/{len(mapping)} runs failed; the largest N did not fail")
        for n, t in sorted((int(n), t) for n, t in mapping.items()):
            print(f"  N={n:4d}  " + ("no failure by --t-end" if t is None else f"t*={t:.6g}"))  # JSON: null
    if args.json and mappings:
        write_json(tstar_report(results), args.json)
        print(f"t*(N) written to {args.json}")
    if args.plot:
        from ..figures.tstar_plot import plot_tstar

        if not curves and interrupted is not None:
            return EXIT_INTERRUPTED[interrupted]  # nothing finished: no plot
        if not curves:
            raise ValueError("nothing to plot: give --N or --load")
        plot_tstar(curves, args.plot, t_end=args.t_end, paper=args.rheology == "mui" and args.scene == "shear",
                   settings={disc: _settings_text(runs) for disc, runs in results.items()})
        print(f"plot written to {args.plot}")
    return 0 if interrupted is None else EXIT_INTERRUPTED[interrupted]
