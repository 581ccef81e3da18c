"""``icidr-pde study sim2d|grid-convergence|references``: the studies behind docs/ whose numbers are
committed under data/ (each study is a function of :mod:`icidr_pde.studies`; this module parses
its options).

* ``study sim2d convergence|tstar|growth|tables``: the 2-D cell (:mod:`icidr_pde.studies.sim2d`,
  data/sim2d, docs/sim2d.md), convergence and tstar at the integrator settings given (``--rtol``,
  ``--atol``, ``--jacobian``; default the study's);
* ``study grid-convergence``: errors against a fine run and the observed orders
  (:func:`icidr_pde.studies.grid_convergence.convergence_study`, docs/results.md);
* ``study references [CASE ...]``: the converged references of the speed-accuracy study
  (:mod:`icidr_pde.studies.references`, data/reference).

The runs of a study are independent: ``--jobs``, ``--workers``, ``--scheduler`` and ``--cache``
(:mod:`.cluster`) as for ``tstar``.
"""

from __future__ import annotations

import json

from .argtypes import add_rheology_option, number, positive_int, subcommand
from .cluster import add_cache_option, add_cluster_options, check_cache_option, client_of

__all__ = ["add_parser", "cmd"]

#: the reference cases that are failure times, besides :data:`icidr_pde.studies.references.CASES`
TSTAR_REFERENCES = ("tstar-fd", "tstar-cheb")


def add_parser(subparsers):
    """Add ``study`` with ``sim2d``, ``grid-convergence`` and ``references``."""
    from ..engines.choose import CHOICES_2D
    from ..scenes import SCENES

    p = subparsers.add_parser("study", help="the studies behind docs/: 2-D cell, grid convergence, converged references",
                              description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="study", required=True)

    s = subcommand(sub, "sim2d", _sim2d, help="the 2-D cell on bump2d and mode2d: convergence, t*, wave growth "
                                              "(data/sim2d), or the tables of docs/sim2d.md from those files")
    s.add_argument("part", choices=["convergence", "tstar", "growth", "tables"])
    s.add_argument("--sizes", type=positive_int, nargs="+", default=None, metavar="N",
                   help="cells per side (convergence, tstar; default: the study's)")
    s.add_argument("--advection", choices=("central", "upwind"), default=None,
                   help="convergence: the advection scheme (default central; upwind writes convergence_upwind.json)")
    s.add_argument("--engine", choices=["petsc"], default=None,
                   help="convergence, tstar: the 2-D runs on the PETSc engine (runs under mpiexec: "
                        "docs/distributed.md) (default: the study's CVODE and GMRES)")
    # the studies' defaults named, not imported: the study module brings numpy and the run path
    s.add_argument("--rtol", type=number, default=None,
                   help="convergence, tstar: CVODE's relative tolerance (default: the study's, 1e-07: "
                        "studies.sim2d.SETTINGS)")
    s.add_argument("--atol", type=number, default=None,
                   help="convergence, tstar: CVODE's absolute tolerance (default: the study's, 1e-10: "
                        "studies.sim2d.SETTINGS)")
    s.add_argument("--jacobian", choices=CHOICES_2D["CVODE"], default=None,
                   help="convergence, tstar: the linear solver of the 2-D CVODE runs, as `run --jacobian` "
                        "(default: the study's, 'krylov': GMRES alone, studies.sim2d.SOLVER_2D; 'fourier' is the "
                        "2-D default of `run`: GMRES preconditioned by the x-Fourier inverse)")
    s.add_argument("--json", default=None, help="write the study's JSON here (default: its file in data/sim2d)")
    add_cluster_options(s, "the study's runs")
    add_cache_option(s, "run")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")

    g = subcommand(sub, "grid-convergence", _grid_convergence,
                   help="errors of coarse runs against a fine run at one time, and the observed orders")
    add_rheology_option(g, "icidr")
    g.add_argument("--scene", choices=sorted(SCENES), default="sine", help="initial condition")
    g.add_argument("--t", type=number, default=5.0, help="time of the comparison")
    g.add_argument("--N", type=positive_int, nargs="+", default=[51, 101, 201, 401], help="coarse grids")
    g.add_argument("--ref", type=positive_int, default=1601, help="the reference grid")
    g.add_argument("--advection", choices=("central", "upwind"), default="upwind", help="advection scheme (fd)")
    g.add_argument("--json", default=None, help="write the errors and orders here")
    add_cluster_options(g, "the grids")
    add_cache_option(g, "grid")
    g.add_argument("--no-progress", action="store_true", help="no progress bar")

    r = subcommand(sub, "references", _references,
                   help="recompute the converged references of the speed-accuracy study (data/reference)")
    r.add_argument("cases", nargs="*", metavar="CASE",
                   help="icidr-shear, icidr-sine, " + ", ".join(TSTAR_REFERENCES) + " (default: all)")
    return p


def cmd(args) -> int:
    """Run the study parsed."""
    return args.func(args)


def _sim2d(args) -> int:
    from ..studies import sim2d

    if args.part == "tables":
        missing = [name for name in ("convergence.json", "tstar.json", "mode_growth.json")
                   if not (sim2d.DATA / name).is_file()]
        if missing:  # the committed studies, relative to the repository's root
            raise ValueError(f"`tables` reads the studies in {sim2d.DATA}/ of the folder it runs in (the "
                             f"repository's root); got no {', '.join(missing)} there")
        print(sim2d.convergence_table(json.loads((sim2d.DATA / "convergence.json").read_text())))
        print()
        print(sim2d.tstar_table(json.loads((sim2d.DATA / "tstar.json").read_text())))
        print()
        print(sim2d.growth_table(json.loads((sim2d.DATA / "mode_growth.json").read_text())))
        for name, table in (("tstar_large.json", sim2d.tstar_table), ("convergence_large.json", sim2d.convergence_table)):
            if (sim2d.DATA / name).is_file():  # the grids beyond 128^2, where committed (docs/sim2d.md)
                print(f"\n{sim2d.DATA / name}:\n")
                print(table(json.loads((sim2d.DATA / name).read_text())))
        return 0
    from ..outputs import check_outputs
    from .common import check_engine

    for option in ("engine", "rtol", "atol", "jacobian"):
        if getattr(args, option) is not None and args.part == "growth":
            raise ValueError(f"`--{option}` applies to the convergence and tstar parts; got --{option} "
                             f"{getattr(args, option)} with growth")
    if args.engine and args.jacobian:  # its Newton systems are sparse matrices, its preconditioner its own
        raise ValueError(f"`--jacobian` chooses the linear solver of the CVODE runs; the PETSc engine has its own: "
                         f"got --jacobian {args.jacobian} with --engine {args.engine}")
    tolerances = {k: getattr(args, k) for k in ("rtol", "atol") if getattr(args, k) is not None}
    if tolerances:
        from ..engines.base import check_tolerances
        from ..studies.sim2d import SETTINGS

        check_tolerances(**{**{k: SETTINGS[k] for k in ("rtol", "atol")}, **tolerances})
    check_engine(args.engine)
    check_outputs({"--json": args.json})
    check_cache_option(args)
    sizes = {"sizes": tuple(args.sizes)} if args.sizes else {}
    if args.advection == "upwind":
        sizes.update(advection="upwind", path=sim2d.DATA / "convergence_upwind.json")
    if args.json:
        sizes.update(path=args.json)
    if args.engine:
        sizes.update(engine=args.engine)
    sizes.update(tolerances)
    if args.jacobian:
        sizes.update(jacobian=args.jacobian)
    studies = {"convergence": lambda **kw: sim2d.convergence_study(**sizes, **kw),
               "tstar": lambda **kw: sim2d.tstar_study(**sizes, **kw),
               "growth": lambda **kw: sim2d.growth_study(**({"path": args.json} if args.json else {}), **kw)}
    with client_of(args, dashboard=not args.no_progress) as client:
        studies[args.part](jobs=args.jobs, client=client, progress=not args.no_progress, cache=args.cache)
    return 0


def _grid_convergence(args) -> int:
    from ..outputs import check_outputs, write_json
    from ..studies.grid_convergence import convergence_study

    check_outputs({"--json": args.json})
    check_cache_option(args)
    with client_of(args, dashboard=not args.no_progress) as client:
        out = convergence_study(args.rheology, args.scene, args.t, args.N, args.ref, args.advection,
                                jobs=args.jobs, client=client, progress=not args.no_progress, cache=args.cache)
    print(json.dumps(out, indent=1))
    if args.json:
        write_json(out, args.json)
    return 0


def _references(args) -> int:
    from ..studies.references import CASES, reference, reference_tstar

    known = [*CASES, *TSTAR_REFERENCES]
    unknown = [name for name in args.cases if name not in known]
    if unknown:
        raise ValueError(f"CASE must be among {known}; got {unknown}")
    for name in args.cases or known:
        if name in TSTAR_REFERENCES:
            print(name, json.dumps(reference_tstar(name.removeprefix("tstar-"), recompute=True)))
            continue
        data = reference(name, recompute=True)
        print(name, json.dumps({k: data["meta"][k] for k in ("space_check", "time_check", "wall_s")}))
    return 0
