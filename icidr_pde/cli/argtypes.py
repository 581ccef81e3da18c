"""argparse types and pieces shared by the command lines (``icidr-pde``, ``python -m icidr_pde.dem``,
``python -m stability`` and the studies' ``python -m`` mains).

:func:`int_at_least` parses with the check of :func:`~icidr_pde.validation.integer`, so that
an option and the API refuse the same values with the same words.
"""

from __future__ import annotations

import argparse

from ..validation import _integer_wanted, integer

__all__ = ["int_at_least", "positive_int", "subcommand", "option_names"]


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
