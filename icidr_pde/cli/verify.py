"""``icidr-pde verify``: every equation of the paper derived and checked with sympy
(:func:`stability.report.verify`), a table of statuses.

Exit status: 0 every equation checks, 1 one fails, 2 bad input.
"""

from __future__ import annotations

__all__ = ["add_parser", "cmd"]


def cmd(args) -> int:
    from stability.report import verify  # noqa: PLC0415
    return verify(json_path=args.json, markdown_path=args.markdown, crosscheck=not args.no_crosscheck)


def add_parser(subparsers):
    """Add ``verify [--json out.json] [--markdown out.md] [--no-crosscheck]``."""
    p = subparsers.add_parser("verify", help="check every equation of the paper symbolically (report table)",
                              description="Derive and check (2.13)-(5.6), (A4)-(A18), (B1)-(B15) with sympy; "
                                          "print a table of statuses (exact / numeric / fails).")
    p.add_argument("--json", metavar="PATH", help="write the report as a JSON list to PATH")
    p.add_argument("--markdown", metavar="PATH", help="write the report as a markdown table to PATH")
    p.add_argument("--no-crosscheck", action="store_true", help="skip the numerical growth-rate cross-checks")
    return p
