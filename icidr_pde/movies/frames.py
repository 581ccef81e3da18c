"""The frames of a movie, collected during a run and rendered at the end: py-pde-free.

:class:`MovieFrames` is a recorder of the run path (:func:`icidr_pde.api.run` with
``movie=...`` calls it at the frame times).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .render import write_movie
from .schedule import frame_times

__all__ = ["MovieFrames"]


class MovieFrames:
    """Frames every `frame_dt` of simulated time, written as a movie by :meth:`write`.

    Frames are copies of the state (3 x N floats each), so memory is frames x 24 N bytes;
    rendering happens once, after the run (also after a failure, then with the state at t*
    as last frame, titled with the reason).

    Args:
        path: .mp4 or .gif file
        z: positions of the unknowns
        t_end: final time
        frame_dt: interval of simulated time between frames (None: see :func:`frame_times`)
        title: movie title
        progress: a bar over the frames while they are written
    """

    def __init__(self, path, z, t_end: float, frame_dt: float | None = None, *, title: str = "", fps: float = 15,
                 progress: bool = False):
        self.output_times = frame_times(t_end, frame_dt)
        path = Path(path)
        if path.suffix.lower() not in (".mp4", ".gif"):
            raise ValueError(f"`movie` must end in .mp4 or .gif; got {path.name!r}")
        if not path.parent.is_dir():
            raise ValueError(f"`movie`: folder {path.parent} does not exist")
        self.path, self.z, self.title, self.fps = path, np.asarray(z), title, fps
        self.frame_dt = frame_dt
        self.progress = progress
        self.failed_reason: str | None = None
        self.times: list[float] = []
        self.frames: list[np.ndarray] = []
        self.written: Path | None = None

    def record(self, t: float, data) -> None:
        self.times.append(float(t))
        self.frames.append(np.array(data, dtype=float, copy=True))

    def failed(self, t: float, data, reason: str) -> None:
        """The last frame of a failed run: the state at t* and why."""
        self.times.append(float(t))
        self.frames.append(np.asarray(data, dtype=float))
        self.failed_reason = reason

    def close(self, outcome) -> None:
        """The end of a run of :func:`icidr_pde.api.run` (its Outcome); rendered later by :meth:`write`."""
        if outcome.blew_up:
            self.failed(outcome.t_final, outcome.final, outcome.reason)

    def abandon(self) -> None:
        pass

    def write(self) -> Path | None:
        """Render the collected frames (``run()`` calls this after timing the solve)."""
        if self.frames and self.written is None:
            self.written = write_movie(self.path, self.z, self.times, np.stack(self.frames), title=self.title,
                                       failed_reason=self.failed_reason, fps=self.fps, progress=self.progress)
        return self.written
