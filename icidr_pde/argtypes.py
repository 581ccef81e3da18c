"""argparse types and pieces shared by the command lines (``icidr-pde`` and ``python -m icidr_pde.dem``).

:func:`int_at_least` is defined in :mod:`icidr_pde.validation` (as the check of
:func:`~icidr_pde.validation.integer` on the text), so that the studies' own options
(``--jobs``/``--workers`` of :mod:`icidr_pde.studies.distributed`), which may not import a
command-line module, parse with the same type.
"""

from __future__ import annotations

import argparse

from .validation import int_at_least

__all__ = ["int_at_least", "positive_int", "subcommand"]


positive_int = int_at_least(1)


def subcommand(subparsers, name, func, **kwargs) -> argparse.ArgumentParser:
    """Add the subcommand `name`, run as ``func(args)``; `kwargs` go to ``add_parser`` (help, description)."""
    parser = subparsers.add_parser(name, **kwargs)
    parser.set_defaults(func=func)
    return parser
