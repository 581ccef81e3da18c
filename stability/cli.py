"""argparse subcommands ``verify``, ``stability`` and ``plot-growth``.

The simulator's ``icidr-pde`` console script wires them in with
:func:`add_verify_parser` and :func:`add_stability_parser` (and optionally
:func:`add_plot_growth_parser`); ``python -m stability ...`` works stand-alone.
Each handler returns an exit code: 0 success, 1 failed verification, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import sys


def _verify(args) -> int:
    from .report import verify  # noqa: PLC0415
    return verify(json_path=args.json, markdown_path=args.markdown, crosscheck=not args.no_crosscheck)


def add_verify_parser(subparsers):
    """Add ``verify [--json out.json] [--markdown out.md] [--no-crosscheck]``."""
    p = subparsers.add_parser("verify", help="check every equation of the paper symbolically (report table)",
                              description="Derive and check (2.13)-(5.6), (A4)-(A18), (B1)-(B15) with sympy; "
                                          "print a table of statuses (exact / numeric / fails).")
    p.add_argument("--json", metavar="PATH", help="write the report as a JSON list to PATH")
    p.add_argument("--markdown", metavar="PATH", help="write the report as a markdown table to PATH")
    p.add_argument("--no-crosscheck", action="store_true", help="skip the numerical growth-rate cross-checks")
    p.set_defaults(func=_verify)
    return p


def _stability(args) -> int:
    from .numeric import stability_numbers  # noqa: PLC0415
    material = None
    try:
        sn = stability_numbers(args.rheology, args.phi, args.uz, args.wz, args.xi, material)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    data = sn.to_json()
    keys = ("M", "chi", "trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "max_re_eig_over_xi2",
            "lambda0_limit")
    print(f"rheology={sn.rheology} phi={sn.phi:g} uz={sn.uz:g} wz={sn.wz:g} xi={sn.xi:g} (d = rho_* = 1)")
    for k in keys:
        print(f"  {k:<20} {data[k]}")
    verdict = "ILL-POSED (Lambda_+ > 0)" if sn.lambda_plus.real > 0 else "well-posed (Lambda_pm < 0)"
    print(f"  {'verdict':<20} {verdict}")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({k: data[k] for k in keys} | {"rheology": sn.rheology, "phi": sn.phi, "uz": sn.uz,
                                                    "wz": sn.wz, "xi": sn.xi}, fh, indent=2)
    return 0


def _positive_float(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def add_stability_parser(subparsers):
    """Add ``stability --rheology {mui,icidr} --phi --uz --wz [--xi] [--json]``."""
    p = subparsers.add_parser("stability", help="symbols of the linearised 1-D system at one base state",
                              description="Print M, chi (A18), tr/det Gamma, Lambda_pm (A9), "
                                          "max Re eig A(xi)/xi^2 and -C/B for a uniform base state.")
    p.add_argument("--rheology", choices=("mui", "icidr"), required=True)
    p.add_argument("--phi", type=_positive_float, required=True, help="packing fraction, in (0, phi_c)")
    p.add_argument("--uz", type=_positive_float, required=True, help="base shear rate d_z u")
    p.add_argument("--wz", type=_positive_float, required=True, help="base dilation rate d_z w")
    p.add_argument("--xi", type=_positive_float, default=1e4, help="wavenumber for eig A(xi) (default 1e4)")
    p.add_argument("--json", metavar="PATH", help="write the numbers as JSON to PATH")
    p.set_defaults(func=_stability)
    return p


def _plot_growth(args) -> int:
    from .growth import plot_fd_growth  # noqa: PLC0415
    path, rows = plot_fd_growth(args.out)
    print(f"{'N':>6} {'h':>10} {'mu(I) max growth':>18} {'iCIDR max growth':>18}")
    for r in rows:
        print(f"{r['N']:>6} {r['h']:>10.5f} {r['mui']:>18.6g} {r['icidr']:>18.6g}")
    print(f"saved {path}")
    return 0


def add_plot_growth_parser(subparsers):
    """Add ``plot-growth [--out docs/fd_growth.png]``."""
    p = subparsers.add_parser("plot-growth", help="plot FD-operator growth rate vs grid spacing (PNG)")
    p.add_argument("--out", default="docs/fd_growth.png", help="output PNG path")
    p.set_defaults(func=_plot_growth)
    return p


def build_parser() -> argparse.ArgumentParser:
    """Stand-alone parser used by ``python -m stability``."""
    parser = argparse.ArgumentParser(prog="python -m stability", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    add_verify_parser(sub)
    add_stability_parser(sub)
    add_plot_growth_parser(sub)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    return args.func(args)
