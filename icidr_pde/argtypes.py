"""argparse types and pieces shared by the command lines (``icidr-pde`` and ``python -m icidr_pde.dem``)."""

from __future__ import annotations

import argparse

__all__ = ["int_at_least", "positive_int", "subcommand"]


def int_at_least(lowest):
    """argparse type: an integer >= `lowest`, the error naming that range and the text received."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < lowest:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lowest}; got {text!r}")
        return value

    parse.__name__ = f"integer >= {lowest}"
    return parse


positive_int = int_at_least(1)


def subcommand(subparsers, name, func, **kwargs) -> argparse.ArgumentParser:
    """Add the subcommand `name`, run as ``func(args)``; `kwargs` go to ``add_parser`` (help, description)."""
    parser = subparsers.add_parser(name, **kwargs)
    parser.set_defaults(func=func)
    return parser
