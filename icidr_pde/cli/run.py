"""``icidr-pde run``: one scene with one rheology, its outcome printed and its results written.

Exit status: 0 reached --t-end; 2 bad input; 3 the run failed (blow-up, non-finite state, phi left
(0, phi_c)), results written; 4 an output could not be written; 130/143 interrupted (SIGINT/SIGTERM),
what was computed up to then written.
"""

from __future__ import annotations

import json
import signal
import sys
import warnings

from .argtypes import add_rheology_option, number, positive_int, time_value
from ..mpi_ranks import speaks
from .common import (EXIT_INTERRUPTED, EXIT_OK, EXIT_RUN_FAILED, EXIT_WRITE_FAILED, PREFIX, check_engine,
                     figure_path, interrupt_signals, is_stdout, write_outputs)

__all__ = ["add_parser", "cmd", "discretization_options"]


def discretization_options() -> dict[str, tuple]:
    """Every option of every registered discretization -> the union of its valid values."""
    from ..discretizations import DISCRETIZATIONS

    out: dict[str, tuple] = {}
    for cls in DISCRETIZATIONS.values():
        for key, valid in cls.options.items():
            out[key] = tuple(dict.fromkeys(out.get(key, ()) + tuple(valid)))
    return out


def add_parser(subparsers):
    """Add ``run`` to the ``icidr-pde`` command."""
    # names from the catalog: building this parser imports neither py-pde nor scipy
    from ..catalog import DISCRETIZATION_OPTIONS, DISCRETIZATIONS, JACOBIAN_MODES, METHODS
    from ..engines.choose import DENSE_2D_CELLS, REQUESTS
    from ..presets import PRESETS
    from ..scenes import SCENES, scene_parameters

    p = subparsers.add_parser(
        "run", help="run one scene with one rheology",
        description="Integrate the shear cell (3.9), 1-D, or 2-D x-periodic with a 2-D scene (cells: --Nx, --Nz), "
                    "with one rheology from one initial condition; "
                    "print the outcome and optionally write a JSON summary, a figure and the snapshots.\n"
                    "exit status: 0 reached --t-end; 2 bad input; 3 failed (blow-up, state left "
                    "(0, phi_c)); 4 an output could not be written; 130/143 interrupted (SIGINT/SIGTERM).")
    add_rheology_option(p, "icidr")
    p.add_argument("--scene", choices=sorted(SCENES), default="shear",
                   help="initial condition; " + "; ".join(
                       f"{dim}-D: " + ", ".join(sorted(n for n, c in SCENES.items() if getattr(c, "dim", 1) == dim))
                       for dim in (1, 2)) + " (shear: (3.16), sine: (5.7))")
    p.add_argument("--accuracy", choices=sorted(PRESETS), default="standard",
                   help="preset for discretization, N, method and tolerances (measured: docs/performance.md, Presets)")
    p.add_argument("--discretization", choices=sorted(DISCRETIZATIONS), default=None,
                   help="default: from --accuracy")
    p.add_argument("--N", type=positive_int, default=None,
                   help="grid cells (fd) or collocation points (cheb) (default: from --accuracy)")
    p.add_argument("--Nx", type=positive_int, default=None, help="cells along x (2-D scenes; default: Nz)")
    p.add_argument("--Nz", type=positive_int, default=None, help="cells along z (2-D scenes; default: Nx or --N)")
    p.add_argument("--t-end", type=number, default=10.0, help="final time")
    p.add_argument("--times", type=time_value, nargs="+", default=None,
                   help="snapshot times in [0, --t-end] (labels of the JSON max_w; default: the scene's)")
    p.add_argument("--rtol", type=number, default=None, help="relative tolerance (default: from --accuracy)")
    p.add_argument("--atol", type=number, default=None, help="absolute tolerance (default: from --accuracy)")
    p.add_argument("--method", choices=METHODS, default=None, help="integrator (default: from --accuracy)")
    p.add_argument("--jacobian", choices=JACOBIAN_MODES, default=None,
                   help="Jacobian of the implicit solves (default: the method's best: analytic for "
                        "BDF/Radau/CVODE, banded-fd for LSODA). On 2-D grids (CVODE): 'fourier' (default: GMRES "
                        "preconditioned by the x-averaged Jacobian, exactly inverted by the FFT in x), 'krylov' "
                        "(GMRES unpreconditioned), 'amg' (GMRES + algebraic multigrid), 'sparse' (SuperLU_MT); "
                        "BDF/Radau: 'analytic' (SuperLU), 'sparse-fd', 'colored-fd'. Dense Newton matrices "
                        "(CVODE 'analytic' or 'none', BDF/Radau 'none', LSODA) are refused on 2-D grids "
                        f"beyond {DENSE_2D_CELLS} cells")
    p.add_argument("--max-order", type=positive_int, default=None,
                   help="highest BDF order of CVODE and PETSc, 1-5 (default: 2 on 2-D grids, A-stable: no "
                        "advected wave is amplified; 5 in 1-D; a higher order in 2-D runs with a warning)")
    for key, (defaults, valid) in DISCRETIZATION_OPTIONS.items():
        p.add_argument(f"--{key}", choices=valid, default=None,
                       help="option of " + ", ".join(f"{name} (default {value})" for name, value in defaults.items()))
    for name, help_text in scene_parameters().items():
        p.add_argument(f"--{name}", type=number, default=None,
                       help=f"scene parameter: {help_text} (default: the scene's)")
    p.add_argument("--json", default=None, help="write the result summary to this file")
    p.add_argument("--plot", default=None, help="write a figure of profiles and max|w|(t) (PNG if no suffix)")
    p.add_argument("--save", default=None, help="write the snapshots to this HDF5 file (z, times, data)")
    p.add_argument("--movie", default=None, help="write a movie of the run (.mp4, or .gif)")
    p.add_argument("--frame-dt", type=number, default=None,
                   help="simulated time between movie frames, independent of --times "
                        "(default: 40 log-spaced frames up to t_end/200, then every t_end/200)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--engine", choices=REQUESTS, default="auto",
                   help="auto: the native engine (C kernels and CVODE compiled once per installation, no "
                        "Python in the loop, no py-pde import) where it applies: fd or cheb, CVODE, analytic Jacobian, "
                        "no --save/--movie; else the py-pde path. native: the same, saying why when it falls "
                        "back. pde: the py-pde path (numba kernels, scikit-sundae or scipy). petsc: PETSc's TS, "
                        "Newton and GMRES (block Jacobi/ILU; -pc_type gamg) on the 2-D cell (the [petsc] extra; PETSC_OPTIONS passes options; "
                        "runs under mpiexec)")
    return p


def _scenes_2d() -> list:
    from ..scenes import SCENES

    return [name for name, scene in SCENES.items() if getattr(scene, "dim", 1) != 1]


def cmd(args) -> int:
    from ..engines.choose import PETSC_METHOD
    from ..outputs import check_outputs
    from ..scenes import SCENES, scene_parameters
    from ..validation import ParameterError

    # a rank other than 0 of an MPI run computes and says nothing: rank 0 prints and writes
    # (icidr_pde.mpi_ranks). Every rank checks the input the same way, so that bad input ends every
    # rank with the same status
    check_engine("petsc" if args.method == PETSC_METHOD else args.engine)
    args.quiet = quiet = not speaks()
    plot = figure_path("--plot", args.plot)
    check_outputs({"--json": args.json, "--save": args.save, "--movie": args.movie, "--plot": plot})
    scene_params = {k: getattr(args, k) for k in scene_parameters() if getattr(args, k) is not None}
    N = args.N
    given = [f"--{k}" for k in ("Nx", "Nz") if getattr(args, k) is not None]
    if given and getattr(SCENES.get(args.scene), "dim", 1) == 1:  # else "--N must be ... got (64, 64)"
        raise ParameterError(f"`{given[0]}` sets the cells of a 2-D scene ({', '.join(_scenes_2d())}); "
                             f"scene {args.scene!r} is 1-D: use --N; got {given[0]} {getattr(args, given[0][2:])}")
    if given:
        nz = args.Nz or args.N or args.Nx
        N = (args.Nx or nz, nz)
    from ..rheology.law_files import is_file_law

    rheology = args.rheology
    if is_file_law(rheology):  # loaded once (a Python file is run once), checked, then run by its name
        from stability.workbench import check_summary

        from ..rheology.law_files import load_law_file

        law = load_law_file(rheology)
        note = None if quiet else check_summary(law(None))
        rheology = law.name
    else:
        note = None
    written = {}  # "result", then "status" once --json and --plot are written

    def write_results(result):  # the finished outputs, before the movie is rendered
        written["result"] = result
        if quiet:
            written["status"] = EXIT_OK
            return
        if note:  # a law that was run (one refused says why instead)
            print(f"icidr-pde: {note}", file=sys.stderr)
        summary = sys.stderr if is_stdout(args.json) else sys.stdout  # stdout then holds only the JSON
        print(result, file=summary)
        print(json.dumps({k: v for k, v in result.to_dict().items()
                          if k in ("blew_up", "t_star", "reason", "t_final", "max_w", "mass_drift", "wall_s")},
                         indent=1), file=summary)
        written["status"] = write_outputs([("--json", args.json, result.save_json),
                                           ("--plot", plot, lambda path: _write_run_plot(result, path))],
                                          report=summary)

    with interrupt_signals() as signals:
        try:
            options = dict(accuracy=args.accuracy, discretization=args.discretization, method=args.method,
                           rtol=args.rtol, atol=args.atol, jacobian=args.jacobian, max_order=args.max_order,
                           advection=args.advection,
                           progress=not (args.no_progress or quiet), save=args.save, movie=args.movie, **scene_params)
            from ..api import run

            with warnings.catch_warnings():  # an output not written: said below, once
                warnings.filterwarnings("ignore", "`(save|movie)` .* was not written", RuntimeWarning)
                result = run(rheology, args.scene, N, args.t_end, args.times, frame_dt=args.frame_dt,
                             engine=args.engine, on_result=write_results, **options)
        except KeyboardInterrupt:
            if "result" not in written and not quiet:  # before the integration started: nothing computed
                print(f"{PREFIX} interrupted before the integration started; nothing written", file=sys.stderr)
            return EXIT_INTERRUPTED[signals.received or signal.SIGINT]
    status = written["status"]
    for name, why in result.not_written.items():
        print(f"{PREFIX} could not write --{name} {getattr(args, name)}: {why}", file=sys.stderr)
        if why != "interrupted":
            status = EXIT_WRITE_FAILED
    if args.movie and "movie" not in result.not_written:
        print(f"movie written to {args.movie}")
    if status:
        return status
    if result.reason.startswith("interrupted") or "interrupted" in result.not_written.values():
        return EXIT_INTERRUPTED[signals.received or signal.SIGINT]
    return EXIT_RUN_FAILED if result.blew_up else EXIT_OK


def _write_run_plot(result, path):
    from ..plotting import plot_result

    plot_result(result, path)
