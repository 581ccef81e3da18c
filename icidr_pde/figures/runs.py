"""The runs the figures share (:data:`RUNS`, public :func:`icidr_pde.run` only), made once per
invocation by a :class:`RunCache` with the paper's ode15s-like settings
(:data:`icidr_pde.movies.registry.PAPER_SETTINGS`), and the snapshot times of figs 3, 6 and 7."""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

import numpy as np

from ..datafiles import data_dir
from ..movies.registry import MOVIES, PAPER_SETTINGS
from ..movies.schedule import frame_times

__all__ = ["BLOWUP_DT", "DATA", "FIG6_TIMES", "FIG7_TIMES", "PAPER_TSTAR_CHEB", "RUNS", "RunCache",
           "RunSpec", "at_resolution"]


DATA = data_dir()  # the committed results (repository data/, or icidr_pde/data in a wheel)
PAPER_TSTAR_CHEB = 0.01052  # fig 4(a) caption
FIG6_TIMES = (0.0, 0.5, 1.0, 2.0, 5.0, 10.0)
FIG7_TIMES = (0.0, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0)
BLOWUP_DT = 2.5e-4  # snapshot interval of the mu(I) fine runs (figure lines every 0.0025, movie frames)


@dataclass(frozen=True)
class RunSpec:
    """Keyword arguments of :func:`icidr_pde.run` for one run, N given as (paper, draft)."""

    rheology: str
    scene: str
    discretization: str
    N: tuple[int, int]
    t_end: float
    times: tuple = ()
    movie: str | None = None

    def kwargs(self, draft: bool) -> dict:
        times = set(self.times)
        if self.movie:
            spec = MOVIES[self.movie]
            t_movie = self.t_end if spec.frame_dt >= 0.01 else 0.1  # blow-ups: frames up to t = 0.1 at most
            times |= set(np.round(frame_times(t_movie, spec.frame_dt), 12))
        return dict(rheology=self.rheology, scene=self.scene, discretization=self.discretization,
                    N=self.N[1] if draft else self.N[0], t_end=self.t_end, times=sorted(times), **PAPER_SETTINGS)


_FINE_BLOWUP = tuple(np.round(np.arange(0, 0.1 + 1e-12, BLOWUP_DT), 12))
RUNS = {
    "mui-fd-fine": RunSpec("mui", "shear", "fd", (201, 101), 10.0, _FINE_BLOWUP, "movie1"),
    "mui-cheb-fine": RunSpec("mui", "shear", "cheb", (201, 101), 10.0, _FINE_BLOWUP, "movie2"),
    "mui-fd-coarse": RunSpec("mui", "shear", "fd", (47, 47), 10.0, FIG6_TIMES, "movie3"),
    "mui-cheb-coarse": RunSpec("mui", "shear", "cheb", (47, 47), 10.0, FIG6_TIMES),
    "icidr-shear-fd-coarse": RunSpec("icidr", "shear", "fd", (47, 47), 10.0, FIG6_TIMES),
    "icidr-shear-fd-fine": RunSpec("icidr", "shear", "fd", (201, 101), 10.0, FIG6_TIMES, "movie4"),
    "icidr-shear-cheb-fine": RunSpec("icidr", "shear", "cheb", (201, 101), 10.0, FIG6_TIMES, "movie5"),
    "icidr-sine-fd-coarse": RunSpec("icidr", "sine", "fd", (47, 47), 20.0, FIG7_TIMES),
    "icidr-sine-fd-fine": RunSpec("icidr", "sine", "fd", (201, 101), 20.0, FIG7_TIMES, "movie6"),
}


class RunCache:
    """Runs of :data:`RUNS`, made on first use and kept for the invocation."""

    def __init__(self, draft: bool = False, verbose: bool = False):
        self.draft, self.verbose = draft, verbose
        self._results: dict = {}
        self.seconds: dict[str, float] = {}

    def __getitem__(self, key: str):
        if key not in self._results:
            from ..api import run

            kwargs = RUNS[key].kwargs(self.draft)
            start = time.perf_counter()
            if self.verbose:
                print(f"  run {key} (N = {kwargs['N']}) ...", flush=True)
            self._results[key] = run(**kwargs)
            self.seconds[key] = time.perf_counter() - start
        return self._results[key]


def at_resolution(text: str, draft: bool) -> str:
    """`text`, which names the paper's grids (N = 201), with each N read as the one a draft
    run uses (:data:`RUNS`: N = 201 -> 101; N = 47 stays)."""
    if not draft:
        return text
    for paper, drafted in {spec.N for spec in RUNS.values() if spec.N[0] != spec.N[1]}:
        text = re.sub(rf"\b{paper}\b", str(drafted), text)
    return text
