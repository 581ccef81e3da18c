"""The py-pde tracker that collects the frames of a movie during a run and writes it at the end."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pde.trackers.base import TrackerBase

from .render import write_movie
from .schedule import frame_times

__all__ = ["MovieTracker"]


class MovieTracker(TrackerBase):
    """Collect frames every `frame_dt` of simulated time and write the movie at the end.

    Frames are copies of the state (3 x N floats each), so memory is frames x 24 N bytes;
    rendering happens once, in :meth:`finalize`, after the run (also after a failure,
    then with the state at t* as last frame: py-pde's ``info["controller"]`` with
    ``successful=False``, ``t_final``, ``stop_reason``, ``state_data``).

    Args:
        path: .mp4 or .gif file
        z: positions of the unknowns
        t_end: final time
        frame_dt: interval of simulated time between frames (None: see :func:`frame_times`)
        title: movie title
        progress: a bar over the frames while they are written
    """

    name = "shear_movie"

    def __init__(self, path, z, t_end: float, frame_dt: float | None = None, *, title: str = "", fps: float = 15,
                 write_on_finalize: bool = True, progress: bool = False):
        super().__init__(interrupts=list(frame_times(t_end, frame_dt)))
        path = Path(path)
        if path.suffix.lower() not in (".mp4", ".gif"):
            raise ValueError(f"`movie` must end in .mp4 or .gif; got {path.name!r}")
        if not path.parent.is_dir():
            raise ValueError(f"`movie`: folder {path.parent} does not exist")
        self.path, self.z, self.title, self.fps = path, np.asarray(z), title, fps
        self.frame_dt = frame_dt
        self.write_on_finalize = write_on_finalize
        self.progress = progress
        self.failed_reason: str | None = None
        self.times: list[float] = []
        self.frames: list[np.ndarray] = []
        self.written: Path | None = None

    def handle(self, field, t: float) -> None:
        self.times.append(float(t))
        self.frames.append(np.array(field.data, copy=True))

    def finalize(self, info=None) -> None:
        super().finalize(info)
        controller = (info or {}).get("controller", {})
        if controller.get("successful") is False and controller.get("state_data") is not None:
            self.times.append(float(controller["t_final"]))
            self.frames.append(np.asarray(controller["state_data"], dtype=float))
            self.failed_reason = controller.get("stop_reason", "failed")
        if self.write_on_finalize:
            self.write()

    def write(self) -> Path | None:
        """Render the collected frames (``run()`` calls this after timing the solve)."""
        if self.frames and self.written is None:
            self.written = write_movie(self.path, self.z, self.times, np.stack(self.frames), title=self.title,
                                       failed_reason=self.failed_reason, fps=self.fps, progress=self.progress)
        return self.written
