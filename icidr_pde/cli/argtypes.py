"""argparse types and pieces shared by the subcommands of ``icidr-pde``.

:func:`int_at_least` parses with the check of :func:`~icidr_pde.validation.integer`, so that
an option and the API refuse the same values with the same words; :func:`add_rheology_option` is
the one ``--rheology`` of the commands that run a law (a registered name or a law file).
"""

from __future__ import annotations

import argparse

from ..validation import _integer_wanted, integer

__all__ = ["int_at_least", "positive_int", "number", "time_value", "rheology_name", "add_rheology_option",
           "subcommand", "option_names"]


def int_at_least(lowest: int, highest: int | None = None):
    """argparse type: the text as an integer >= `lowest` (and <= `highest` if given: the check of
    :func:`~.validation.integer`), else argparse's error naming that range and the text received.
    The one such type of every command line, the studies' ``--jobs``/``--workers`` among them."""
    def parse(text):
        try:
            return integer("value", int(text), lowest, highest)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {_integer_wanted(lowest, highest)}; got {text!r}") from None

    parse.__name__ = _integer_wanted(lowest, highest)
    return parse


positive_int = int_at_least(1)


def rheology_name(text):
    """argparse type: a registered rheology or a law file ``*.toml`` (data) or ``*.py`` (a program:
    it is run), checked when the law is built."""
    from ..rheology import RHEOLOGIES

    if text in RHEOLOGIES or text.endswith((".py", ".toml")):
        return text
    raise argparse.ArgumentTypeError(f"must be one of {sorted(RHEOLOGIES)} or a law file *.toml or *.py, "
                                     f"got {text!r}")


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


def add_rheology_option(parser, default: str, help_text: str = "the constitutive law") -> None:
    """``--rheology NAME|FILE``: a registered law or a law file, the same for every command that runs one."""
    from ..rheology import RHEOLOGIES

    parser.add_argument("--rheology", type=rheology_name, default=default, metavar="NAME|FILE",
                        help=f"{help_text}: one of {', '.join(sorted(RHEOLOGIES))} (mui: mu(I),Phi(I) "
                             "(3.13)-(3.15); icidr: inertial CIDR (5.3)-(5.5)), or a law file: *.toml (formulas, "
                             "read as data) or *.py (a Python program: it is RUN with your rights; only files you "
                             "would run yourself; see docs/security.md and `law check`)")


def subcommand(subparsers, name, func, **kwargs) -> argparse.ArgumentParser:
    """Add the subcommand `name`, run as ``func(args)``; `kwargs` go to ``add_parser`` (help, description)."""
    parser = subparsers.add_parser(name, **kwargs)
    parser.set_defaults(func=func)
    return parser


def option_names(message: str, args) -> str:
    """Name the command-line option where the API names its parameter (`t_end` -> `--t-end`)."""
    for dest in vars(args):
        message = message.replace(f"`{dest}`", f"`--{dest.replace('_', '-')}`")
    return message
