"""``icidr-pde figures [--only fig3 fig7 ...] [--out docs/figures] [--draft] [--movies]``."""

from __future__ import annotations

import json
import time
from pathlib import Path

from ..outputs import writable_folder, write_atomically
from ..figures.gallery import write_gallery
from ..figures.make import make_figures, make_movies, movie_names
from ..figures.registry import FIGURES
from ..figures.runs import RunCache

__all__ = ["DRAFT_OUT", "GALLERY", "add_parser", "cmd_figures"]


GALLERY = "docs/figures"  # the committed gallery (paper resolution)
DRAFT_OUT = "figures-draft"  # where `icidr-pde figures --draft` writes unless told otherwise


def add_parser(subparsers):
    p = subparsers.add_parser("figures", help="redraw the paper's figures (and movies 1-6) into docs/figures")
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
    p.set_defaults(func=cmd_figures)
    return p


def _full_resolution(out: Path) -> bool:
    """True where `out` holds a gallery (numbers.json) with a figure drawn at the paper's resolution."""
    store = out / "numbers.json"
    try:
        figures = json.loads(store.read_text()).get("figures", {})
    except (OSError, ValueError):
        return False
    return any(not nums.get("draft", False) for nums in figures.values())


def cmd_figures(args) -> int:
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
