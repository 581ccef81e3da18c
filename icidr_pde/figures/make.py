"""Drawing the registered figures into a folder and the movies from the shared runs."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ..outputs import save_figure
from .panels import pyplot
from .registry import FIGURES
from .runs import RUNS, RunCache, at_resolution
from .two_d import bump2d_pair

__all__ = ["make_figures", "make_movies", "movie_names", "movie2d"]


def make_figures(only=None, out="docs/figures", *, draft=False, verbose=True, runs: RunCache | None = None,
                 dpi=110) -> dict:
    """Draw the figures named in `only` (default: all) into `out`; return {name: numbers}."""
    plt = pyplot()
    names = list(FIGURES) if not only else list(only)
    unknown = [n for n in names if n not in FIGURES]
    if unknown:
        raise ValueError(f"`only` must name figures of {sorted(FIGURES)}; got {unknown}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    runs = runs or RunCache(draft=draft, verbose=verbose)
    numbers = {}
    for name in names:
        start = time.perf_counter()
        if verbose:
            print(f"{name} ...", flush=True)
        fig, nums = FIGURES[name].draw(runs)
        path = out / f"{name}.png"
        save_figure(fig, path, dpi=dpi)
        plt.close(fig)
        nums = {"png": path.name, "seconds": round(time.perf_counter() - start, 2), "draft": draft, **nums}
        numbers[name] = nums
        if verbose:
            print(f"  {FIGURES[name].heading(nums, draft)} -> {path} ({nums['seconds']} s)")
    return numbers


def movie2d(runs, path, *, verbose=True, dpi=90, stride=1) -> dict:
    """The 2-D movie: bump2d, mu(I),Phi(I) up to its failure against iCIDR at the same times
    (the runs of the ``bump2d`` figure, :func:`bump2d_pair`; every `stride`-th snapshot).
    Returns what the gallery lists."""
    from ..movies.render import movie_from_results_2d

    pair = bump2d_pair(runs)
    mui, icidr = pair["mui"], pair["icidr"]
    start = time.perf_counter()
    title = f"bump2d {mui.Nx}x{mui.N}: mu(I),Phi(I) (left) | iCIDR (right)" + (" [draft]" if runs.draft else "")
    path = movie_from_results_2d({"mu(I),Phi(I)": mui, "iCIDR": icidr}, path, title=title, progress=verbose,
                                 dpi=dpi, stride=stride)
    kept = len(set(range(0, len(mui.times), stride)) | {len(mui.times) - 1})
    info = {"file": path.name, "frame_dt": float(np.mean(np.diff(mui.times))) * stride, "frames": kept + mui.blew_up,
            "seconds": round(time.perf_counter() - start, 1), "t_star": mui.t_star, "grid": f"{mui.Nx}x{mui.N}"}
    if verbose:
        print(f"movie2d: {path} ({info['seconds']} s)")
    return info


def movie_names(only=None) -> list[str]:
    """The movies `only` names (default: all); ValueError naming the unknown ones, checked before
    any figure or movie is computed."""
    from ..movies.registry import MOVIES, MOVIES_2D

    known = list(MOVIES) + list(MOVIES_2D)
    names = known if not only else list(only)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"`movies` must name movies of {known}; got {unknown}")
    return names


def make_movies(only=None, out="docs/figures", *, draft=False, runs: RunCache | None = None, verbose=True,
                suffix=".mp4") -> dict:
    """Write the movies (default: supplementary movies 1-6 and movie2d) from the shared runs."""
    from ..movies.render import movie_from_result
    from ..movies.registry import MOVIES, MOVIES_2D

    names = movie_names(only)
    runs = runs or RunCache(draft=draft, verbose=verbose)
    key_of = {spec.movie: key for key, spec in RUNS.items() if spec.movie}
    written = {}
    for name in names:
        if name in MOVIES_2D:
            written[name] = movie2d(runs, Path(out) / f"{name}{suffix}", verbose=verbose)
            continue
        spec = MOVIES[name]
        res = runs[key_of[name]]
        start = time.perf_counter()
        path = movie_from_result(res, Path(out) / f"{name}{suffix}", frame_dt=spec.frame_dt,
                                 title=f"movie {name[5:]}: {at_resolution(spec.caption, draft)}"
                                       + (" [draft]" if draft else ""))
        written[name] = {"file": path.name, "frame_dt": spec.frame_dt, "seconds": round(time.perf_counter() - start, 1),
                         "t_star": res.t_star, "draft": draft}
        if verbose:
            print(f"{name}: {path} ({written[name]['seconds']} s)")
    return written
