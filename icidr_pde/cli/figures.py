"""``icidr-pde figures [--only fig3 fig7 ...] [--out docs/figures] [--draft] [--movies]``: the paper's
figures and movies, a gallery page beside them; ``icidr-pde figures NAME`` draws one figure of docs/
instead: ``sim2d-fields`` (:mod:`icidr_pde.figures.sim2d_fields`), ``fd-growth``
(:func:`stability.growth.plot_fd_growth`), ``plane-waves`` (:mod:`stability.directional`,
:mod:`stability.oblique_growth`)."""

from __future__ import annotations

import json
import time
from pathlib import Path

from ..outputs import writable_folder, write_atomically
from .argtypes import int_at_least, subcommand
from ..figures.gallery import write_gallery
from ..figures.make import make_figures, make_movies, movie_names
from ..figures.registry import FIGURES
from ..figures.runs import RunCache

__all__ = ["DRAFT_OUT", "GALLERY", "add_parser", "cmd"]


GALLERY = "docs/figures"  # the committed gallery (paper resolution)
DRAFT_OUT = "figures-draft"  # where `icidr-pde figures --draft` writes unless told otherwise


def add_parser(subparsers):
    p = subparsers.add_parser("figures", help="redraw the paper's figures (and movies 1-6) into docs/figures, or one figure "
                                             "of docs/")
    p.description = ("Redraw the paper's figures (and movies) with numbers.json and a gallery page README.md. "
                     f"A --draft run writes into {DRAFT_OUT}/ unless --out names another folder, and never "
                     "into a folder holding a full-resolution gallery (docs/figures) without --force.")
    p.add_argument("--only", nargs="+", default=None, metavar="NAME",
                   help=f"figures to draw (default: all): {' '.join(FIGURES)}")
    p.add_argument("--out", default=None,
                   help=f"output folder (PNGs, numbers.json, README.md) "
                        f"(default: {GALLERY}, with --draft {DRAFT_OUT})")
    p.add_argument("--draft", action="store_true", help="N = 101 instead of 201 (same findings, a fraction of the cost)")
    p.add_argument("--force", action="store_true",
                   help="with --draft: write into --out even where it holds a full-resolution gallery")
    p.add_argument("--movies", nargs="*", default=None, metavar="MOVIE",
                   help="also write the movies (all, or those named: movie1 ... movie6, movie2d)")
    p.add_argument("--gif", action="store_true", help="movies as GIF instead of MP4")
    one = p.add_subparsers(dest="figure", metavar="FIGURE",
                           title="one figure of docs/ instead of the gallery (FIGURE --help: its options)")
    s = subcommand(one, "sim2d-fields", _sim2d_fields,
                   help="docs/sim2d_fields.png and docs/sim2d.mp4: w and phi - phi0 on bump2d, both rheologies")
    s.add_argument("--out", type=Path, default=Path("docs"), help="folder of sim2d_fields.png and sim2d.mp4")
    s.add_argument("--N", type=int_at_least(8), default=64, help="cells per side of the field images")
    s.add_argument("--movie-N", type=int_at_least(8), default=48, help="cells per side of the movie")
    s.add_argument("--frames", type=int_at_least(2), default=60, help="snapshots in the movie")
    g = subcommand(one, "fd-growth", _fd_growth, help="growth rate of the finite-difference operator against the "
                                                      "grid spacing (docs/fd_growth.png)")
    g.add_argument("--out", default="docs/fd_growth.png", help="output PNG path")
    w = subcommand(one, "plane-waves", _plane_waves,
                   help="polar plot of Lambda_max(theta) and the measured growth of oblique waves (two PNGs)")
    w.add_argument("--polar", default="docs/polar_stability.png", help="polar plot PNG path")
    w.add_argument("--growth", default="docs/oblique_growth.png", help="measured oblique growth PNG path")
    return p


def _full_resolution(out: Path) -> bool:
    """True where `out` holds a gallery (numbers.json) with a figure drawn at the paper's resolution."""
    store = out / "numbers.json"
    try:
        figures = json.loads(store.read_text()).get("figures", {})
    except (OSError, ValueError):
        return False
    return any(not nums.get("draft", False) for nums in figures.values())


def cmd(args) -> int:
    """The gallery, or the one figure named."""
    return _gallery(args) if args.figure is None else args.func(args)


def _gallery(args) -> int:
    import datetime

    start = time.perf_counter()
    if args.movies is not None:
        movie_names(args.movies or None)  # before the folder is made and fig 3 computed for nothing
    out = writable_folder("--out", args.out if args.out is not None else DRAFT_OUT if args.draft else GALLERY)
    if args.draft and not args.force and _full_resolution(out):
        raise ValueError(f"`out` {out} holds a full-resolution gallery that a draft would overwrite: "
                         f"omit --out (a draft goes to {DRAFT_OUT}), name another folder, or add --force")
    runs = RunCache(draft=args.draft, verbose=True)
    numbers = make_figures(args.only, out, draft=args.draft, runs=runs)
    movies = None
    if args.movies is not None:
        movies = make_movies(args.movies or None, out, draft=args.draft, runs=runs,
                             suffix=".gif" if args.gif else ".mp4")
    total = time.perf_counter() - start
    store = out / "numbers.json"
    previous = json.loads(store.read_text()) if store.exists() else {}
    figures = {**previous.get("figures", {}), **numbers}
    movies_all = {**previous.get("movies", {}), **(movies or {})}
    meta = previous.get("meta", {})
    if not args.only:  # a complete run: its time is the one to quote
        meta = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                "total_s": total, "draft": args.draft, "movies": movies is not None,
                "run_seconds": {k: round(v, 1) for k, v in runs.seconds.items()}}
    text = json.dumps({"meta": meta, "figures": figures, "movies": movies_all}, indent=1)
    write_atomically(store, lambda fh: fh.write(text))
    write_gallery(figures, out, movies_all or None, meta)
    print(f"{len(numbers)} figure(s){' and %d movie(s)' % len(movies) if movies else ''} in {out} ({total:.0f} s)")
    return 0


def _sim2d_fields(args) -> int:
    """``figures sim2d-fields``: the field images and the movie of docs/sim2d.md."""
    from ..figures.sim2d_fields import field_figure, movie

    if not args.out.is_dir():
        raise ValueError(f"`--out`: folder {args.out} does not exist")
    print(f"figure written to {field_figure(args.out / 'sim2d_fields.png', args.N)}")
    print(f"movie written to {movie(args.out / 'sim2d.mp4', args.movie_N, args.frames)}")
    return 0


def _fd_growth(args) -> int:
    """``figures fd-growth``: docs/fd_growth.png and its table."""
    from stability.growth import plot_fd_growth  # noqa: PLC0415
    path, rows = plot_fd_growth(args.out)
    print(f"{'N':>6} {'h':>10} {'mu(I) max growth':>18} {'iCIDR max growth':>18}")
    for r in rows:
        print(f"{r['N']:>6} {r['h']:>10.5f} {r['mui']:>18.6g} {r['icidr']:>18.6g}")
    print(f"saved {path}")
    return 0


def _plane_waves(args) -> int:
    """``figures plane-waves``: docs/polar_stability.png, docs/oblique_growth.png and their tables."""
    from stability.directional import directional_stability  # noqa: PLC0415
    from stability.oblique_growth import plot_oblique_growth  # noqa: PLC0415
    import matplotlib  # noqa: PLC0415
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415
    from stability.directional import plot_polar  # noqa: PLC0415

    states = [("steady shear", (0.0, 1 / 30, 0.0, 0.0)), ("fig. 2 state", (0.0, 1 / 30, 0.0, 0.05))]
    fig, axes = plt.subplots(1, 2, subplot_kw={"projection": "polar"}, figsize=(11, 6.8))
    for ax, (label, L) in zip(axes, states):
        rs = [directional_stability(n, 0.78, L) for n in ("mui", "icidr")]
        plot_polar(rs, ax, title=rf"{label}: $\phi_0$ = 0.78, $u_z$ = {L[1]:.4g}, $w_z$ = {L[3]:g}")
        for r in rs:
            iv = ", ".join(f"[{a:.4f}, {b:.4f}]" for a, b in r.ill_posed_intervals_deg) or "none"
            print(f"{label:<13} {r.rheology:<6} max_lambda {r.max_lambda:.6g} at {r.worst_angle_deg:.4f} deg; "
                  f"lambda_max(90) {r.at_90_deg['lambda_plus'].real:.6g}; ill-posed {iv}")
    fig.tight_layout()
    from icidr_pde.outputs import save_figure  # noqa: PLC0415

    save_figure(fig, args.polar, dpi=120)
    plt.close(fig)
    print(f"saved {args.polar}")
    _, rows = plot_oblique_growth(args.growth)
    print(f"{'rheology':<8} {'xi':>6} {'theta':>6} {'measured':>16} {'predicted':>16} {'rel. error':>10}")
    for r in rows:
        print(f"{r['rheology']:<8} {r['xi']:>6g} {r['angle_deg']:>6g} {r['measured']:>16.9g} {r['predicted']:>16.9g} "
              f"{r['rel_error']:>10.1e}")
    print(f"saved {args.growth}")
    return 0
