"""What a run writes or shows besides its Result, and the wall-clock limit: the recorders.

A :class:`Recorder` is called by the drive loop (:mod:`icidr_pde.drive`) at its
``output_times`` with the fields of the state there (fields first: phi, u, w), whichever engine
integrates, then closed with the run's Outcome, or abandoned if the run raised. The recorders
of a run (:func:`make_recorders`): the live figure (:class:`~icidr_pde.live_plot.LivePlot`), the
movie frames (:class:`~icidr_pde.movies.frames.MovieFrames`), the snapshot file
(:class:`~icidr_pde.snapshots.SnapshotFile`) and the wall-clock limit (:class:`WallClock`).
Each is imported only by the runs that ask for it.
"""

from __future__ import annotations

import time as _time
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Recorder", "StopRun", "WallClock", "make_recorders"]


@runtime_checkable
class Recorder(Protocol):
    """The contract of a recorder.

    Attributes:
        output_times: the times (> 0, or 0 for the initial state) at which it is called
    """

    output_times: np.ndarray

    def record(self, t: float, data) -> None:
        """The fields `data` (3, ...) of the state at time t (a copy is the recorder's to keep).
        Raising :class:`StopRun` ends the run at this output."""

    def close(self, outcome) -> None:
        """The run has ended, however (its :class:`~icidr_pde.drive.Outcome`): keep what was recorded."""

    def abandon(self) -> None:
        """The run raised: leave every output as it was before the run."""


class StopRun(Exception):
    """Raised by a recorder to end a run early (a wall-clock limit): the run ends at the
    output being recorded, with this reason, not as a failure."""


class WallClock:
    """A recorder that ends the run once it has taken `max_wall` seconds (checked at 200 times)."""

    def __init__(self, max_wall: float, t_end: float):
        self.max_wall = max_wall
        self.output_times = np.geomspace(min(1e-4, t_end / 10), t_end, 200)
        self.start = _time.perf_counter()

    def record(self, t: float, data) -> None:
        if _time.perf_counter() - self.start > self.max_wall:
            raise StopRun(f"timeout after {self.max_wall} s wall at t = {t:.6g}")

    def close(self, outcome) -> None:
        pass

    def abandon(self) -> None:
        pass


def make_recorders(case, t_end: float, *, snap_times, save=None, live_plot=False, movie=None, frame_dt=None,
                   progress=False, max_wall=None, chi=None) -> list:
    """The recorders of a run of `case`, called by the drive loop at their `output_times` with the
    fields of the state, then closed with the Outcome: the live figure (with `chi(data)` ->
    (positions, chi of (A18)) for mu(I)), the movie frames, the snapshot file (last: a temporary
    file, created once nothing else can fail) and the wall-clock limit (last at each time: what the
    others recorded stays)."""
    recorders = []
    title = f"{case.rheology.name} {case.scene.name} {case.discretization} N={case.N}"
    if (live_plot or movie) and not case.cell.profiles:
        raise ValueError("`live_plot` and `movie` draw 1-D scenes (fields against z); "
                         f"got the 2-D scene {case.scene.name!r}")
    if live_plot:
        from .live_plot import LivePlot

        chi = chi if case.rheology.name == "mui" else None  # (A18): mu(I) ill-posed
        recorders.append(LivePlot(case.nodes(), t_end, chi=chi, title=title))
    if movie:  # rendered by run() after the timing
        from .movies.frames import MovieFrames

        recorders.append(MovieFrames(movie, case.nodes(), t_end, frame_dt, title=title, progress=progress))
    if save:
        from .snapshots import SnapshotFile

        recorders.append(SnapshotFile(save, case.nodes(), snap_times, case.state))  # never half-written
    if max_wall is not None:
        recorders.append(WallClock(max_wall, t_end))
    return recorders
