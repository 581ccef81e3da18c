"""``icidr-pde stability``: the symbol of the linearised system at one uniform state (1-D; plane
waves in the x-z plane; with ``--dim 3`` every direction of space), from :mod:`stability`.

Exit status: 0 success, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import sys


ONE_D_KEYS = ("M", "chi", "trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "max_re_eig_over_xi2",
              "lambda0_limit")


def _print_one_d(sn, data):
    print(f"rheology={sn.rheology} phi={sn.phi:g} uz={sn.uz:g} wz={sn.wz:g} xi={sn.xi:g} (d = rho_* = 1)")
    for k in ONE_D_KEYS:
        print(f"  {k:<20} {data[k]}")
    verdict = "ILL-POSED (Lambda_+ > 0)" if sn.lambda_plus.real > 0 else "well-posed (Lambda_pm < 0)"
    print(f"  {'verdict':<20} {verdict}")


def _one_d_json(sn):
    data = sn.to_json()
    return {k: data[k] for k in ONE_D_KEYS} | {"rheology": sn.rheology, "phi": sn.phi, "uz": sn.uz, "wz": sn.wz,
                                               "xi": sn.xi}


def _write_json(path, obj):
    """Write JSON whole or not at all (:mod:`icidr_pde.outputs`)."""
    from icidr_pde.outputs import write_atomically  # noqa: PLC0415

    write_atomically(path, lambda fh: json.dump(obj, fh, indent=2))


def cmd(args) -> int:
    from .argtypes import option_names  # noqa: PLC0415
    from icidr_pde.outputs import check_outputs  # noqa: PLC0415

    from stability.numeric import stability_numbers  # noqa: PLC0415
    material = None
    if args.dim == 3:
        return _stability_3d(args)
    two_d = args.velocity_gradient is not None or args.angles is not None or args.plot is not None
    try:
        check_outputs({"--json": args.json, "--plot": args.plot})
        if args.directions is not None:
            raise ValueError(f"`directions` samples the sphere of `--dim 3`; got {args.directions} with --dim 2 "
                             "(2-D directions: --angles)")
        if args.velocity_gradient is not None:
            if args.uz is not None or args.wz is not None:
                raise ValueError("give either `--velocity-gradient U_X U_Z W_X W_Z` or `--uz`/`--wz`, not both")
            from stability.directional import check_gradient  # noqa: PLC0415
            grad = check_gradient(args.velocity_gradient)
        elif args.uz is None or args.wz is None:
            raise ValueError("need `--velocity-gradient U_X U_Z W_X W_Z`, or both `--uz` and `--wz` (1-D); got "
                             f"uz={args.uz}, wz={args.wz}")
        else:
            grad = (0.0, args.uz, 0.0, args.wz)
        one_d = grad[0] == 0 and grad[2] == 0
        sn = stability_numbers(args.rheology, args.phi, grad[1], grad[3], args.xi, material) if one_d else None
        ds = None
        if two_d:
            from stability.directional import directional_stability, parse_angles  # noqa: PLC0415
            angles = parse_angles(args.angles if args.angles is not None else "0:180:1")
            ds = directional_stability(args.rheology, args.phi, grad, angles, material, xi=args.xi)
    except ValueError as e:
        print(f"icidr-pde: error: {option_names(str(e), args)}", file=sys.stderr)
        return 2
    out = {}
    if sn is not None:
        _print_one_d(sn, sn.to_json())
        out = _one_d_json(sn)
    if ds is not None:
        _print_directional(ds, args.angles or "0:180:1")
        out = ds.to_json() | out          # the 1-D keys (when grad u has the 1-D form) as today
        if args.plot:
            from stability.directional import save_polar  # noqa: PLC0415
            save_polar([ds], args.plot, title=_title(ds))
            print(f"  saved {args.plot}")
    if args.json:
        _write_json(args.json, out)
    return 0


def _stability_3d(args) -> int:
    """``--dim 3``: the 3-D symbol over the sphere of wave directions (:mod:`stability.spatial`)."""
    from .argtypes import option_names  # noqa: PLC0415
    from icidr_pde.outputs import check_outputs  # noqa: PLC0415

    from stability import spatial  # noqa: PLC0415
    try:
        check_outputs({"--json": args.json, "--plot": args.plot})
        if args.angles is not None:
            raise ValueError(f"`angles` are the directions of the x-z plane (--dim 2); got {args.angles!r} with "
                             "--dim 3, whose directions are --directions N on the sphere")
        if args.velocity_gradient is not None:
            if args.uz is not None or args.wz is not None:
                raise ValueError("give either `--velocity-gradient` or `--uz`/`--wz`, not both")
            g = args.velocity_gradient
            if len(g) == 4:
                from stability.directional import check_gradient  # noqa: PLC0415
                L = spatial.planar_gradient(*check_gradient(g))
            elif len(g) == 9:
                L = spatial.check_gradient(g)
            else:
                raise ValueError("`velocity_gradient` with --dim 3 must be 9 numbers U_X U_Y U_Z V_X V_Y V_Z W_X W_Y "
                                 f"W_Z (row-major grad u) or 4 numbers U_X U_Z W_X W_Z (a planar flow); got {len(g)}")
        elif args.uz is None or args.wz is None:
            raise ValueError("need `--velocity-gradient` (9 numbers, or 4 of a planar flow), or both `--uz` and "
                             f"`--wz`; got uz={args.uz}, wz={args.wz}")
        else:
            from stability.directional import check_gradient  # noqa: PLC0415
            L = spatial.planar_gradient(*check_gradient((0.0, args.uz, 0.0, args.wz)))
        directions = spatial.DIRECTIONS if args.directions is None else args.directions
        r = spatial.spatial_stability(args.rheology, args.phi, L, directions)
    except ValueError as e:
        print(f"icidr-pde: error: {option_names(str(e), args)}", file=sys.stderr)
        return 2
    _print_spatial(r)
    if args.plot:
        import matplotlib  # noqa: PLC0415
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt  # noqa: PLC0415
        from icidr_pde.outputs import save_figure  # noqa: PLC0415

        fig, ax = plt.subplots(figsize=(7, 3.8))
        spatial.plot_sphere(r, ax)
        fig.tight_layout()
        try:
            save_figure(fig, args.plot, dpi=120)
        finally:
            plt.close(fig)
        print(f"  saved {args.plot}")
    if args.json:
        _write_json(args.json, r.to_json())
    return 0


def _print_spatial(r):
    rows = "; ".join(", ".join(f"{v:g}" for v in row) for row in r.velocity_gradient)
    print(f"3-D plane waves, n on the unit sphere: rheology={r.rheology} phi={r.phi:g} grad u = [{rows}] "
          f"({r.directions} Fibonacci directions, spacing {r.spacing_deg:.2g} deg)")
    w = r.to_json()["worst_direction_deg"]
    print(f"  {'max_lambda':<24} {r.max_lambda!r}")
    print(f"  {'worst_direction':<24} ({', '.join(f'{v:.6g}' for v in r.worst_direction)}) (polar "
          f"{w['polar']:.4g} deg from z, azimuth {w['azimuth']:.4g} deg from x)")
    print(f"  {'ill_posed_fraction':<24} {r.ill_posed_fraction!r}")
    verdict = (f"ILL-POSED for {100 * r.ill_posed_fraction:.4g} % of the wave directions" if not r.well_posed
               else "well-posed in every sampled direction (Lambda_max < 0)")
    print(f"  {'verdict':<24} {verdict}")


def _title(ds):
    ux, uz, wx, wz = ds.velocity_gradient
    return (rf"{ds.rheology}: $\phi_0$ = {ds.phi:g}, $\nabla u$ = [[{ux:.4g}, {uz:.4g}], [{wx:.4g}, {wz:.4g}]]")


def _print_directional(ds, angles_text):
    ux, uz, wx, wz = ds.velocity_gradient
    print(f"2-D plane waves n = (cos theta, sin theta): rheology={ds.rheology} phi={ds.phi:g} "
          f"grad u = [[{ux:g}, {uz:g}], [{wx:g}, {wz:g}]] angles {angles_text} ({ds.angles_deg.size} samples)")
    iv = ", ".join(f"[{a:.6g}, {b:.6g}]" for a, b in ds.ill_posed_intervals_deg) or "none"
    print(f"  {'max_lambda':<24} {ds.max_lambda!r}")
    print(f"  {'worst_angle_deg':<24} {ds.worst_angle_deg!r}")
    print(f"  {'ill_posed_intervals_deg':<24} {iv}")
    print(f"  {'lambda_max at 90 deg':<24} {ds.at_90_deg['lambda_plus'].real!r} (the 1-D direction e_z)")
    step = max(1, ds.angles_deg.size // 12)
    print("  " + "  ".join(f"{t:g}:{v:.4g}" for t, v in zip(ds.angles_deg[::step], ds.lambda_max[::step])))
    verdict = (f"ILL-POSED for plane waves at theta in {iv} deg" if ds.ill_posed_intervals_deg
               else "well-posed in every sampled direction (lambda_max < 0)")
    print(f"  {'verdict':<24} {verdict}")


def _positive_float(text):
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def add_parser(subparsers):
    """Add ``stability --rheology NAME --phi (--uz --wz | --velocity-gradient ...) [--dim 2|3] [--angles | --directions]
    [--xi] [--json] [--plot]``."""
    p = subparsers.add_parser("stability", help="symbols of the linearised 1-D system / 2-D plane waves at one state",
                              description="1-D (--uz --wz): print M, chi (A18), tr/det Gamma, Lambda_pm (A9), "
                                          "max Re eig A(xi)/xi^2 and -C/B for a uniform base state. 2-D "
                                          "(--velocity-gradient U_X U_Z W_X W_Z): Lambda_max(theta) of plane waves "
                                          "n = (cos theta, sin theta), ill-posed angle intervals, worst angle "
                                          "(theta = 90 deg is the 1-D direction). 3-D (--dim 3): the symbol with the 3-D "
                                          "deviator for any 3x3 gradient, over the sphere of wave directions.")
    from icidr_pde.rheology import RHEOLOGIES  # noqa: PLC0415

    p.add_argument("--rheology", choices=sorted(RHEOLOGIES), required=True)
    p.add_argument("--phi", type=_positive_float, required=True, help="packing fraction, in (0, phi_c)")
    p.add_argument("--uz", type=_positive_float, default=None, help="1-D base shear rate d_z u")
    p.add_argument("--wz", type=_positive_float, default=None, help="1-D base dilation rate d_z w")
    p.add_argument("--dim", type=int, choices=(2, 3), default=2,
                   help="2 (default): the 1-D symbol and plane waves in the x-z plane; 3: plane waves in every "
                        "direction of space with the 3-D deviator S = D - (div u/3) I (worst direction, rate, "
                        "ill_posed_fraction of the sphere)")
    p.add_argument("--velocity-gradient", type=_positive_float, nargs="+", metavar="L",
                   default=None, help="base velocity gradient: U_X U_Z W_X W_Z, grad u = [[u_x, u_z], [w_x, w_z]] "
                                      "(--dim 2, or a planar flow with --dim 3); with --dim 3 also the nine "
                                      "U_X U_Y U_Z V_X V_Y V_Z W_X W_Y W_Z (row-major, L[i, j] = d_j u_i)")
    p.add_argument("--directions", type=int, default=None, metavar="N",
                   help="--dim 3: Fibonacci directions on the sphere (default 2000, spacing about 4.5 deg)")
    p.add_argument("--angles", default=None, metavar="START:STOP:STEP",
                   help="plane-wave angles in degrees (default 0:180:1; theta and theta + 180 are one direction)")
    p.add_argument("--xi", type=_positive_float, default=1e4, help="wavenumber for eig A(xi) (default 1e4)")
    p.add_argument("--json", metavar="PATH", help="write the numbers as JSON to PATH")
    p.add_argument("--plot", metavar="PNG", default=None,
                   help="write the polar plot of Lambda_max(theta) (--dim 3: the map of Lambda_max(n) on the sphere) "
                        "to PNG")
    return p
