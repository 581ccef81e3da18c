"""The py-pde tracker that collects the frames of a movie during a run and writes it at the end."""

from __future__ import annotations

from pde.trackers.base import TrackerBase

from .frames import MovieFrames

__all__ = ["MovieTracker"]


class MovieTracker(MovieFrames, TrackerBase):
    """py-pde's tracker of :class:`~.frames.MovieFrames` (same arguments): frames at the
    interrupts, written in :meth:`finalize` (unless `write_on_finalize` is False), also
    after a failure, then with the state at t* as last frame (py-pde's ``info["controller"]``
    with ``successful=False``, ``t_final``, ``stop_reason``, ``state_data``)."""

    name = "shear_movie"

    def __init__(self, path, z, t_end: float, frame_dt: float | None = None, *, write_on_finalize: bool = True,
                 **kwargs):
        MovieFrames.__init__(self, path, z, t_end, frame_dt, **kwargs)
        TrackerBase.__init__(self, interrupts=list(self.output_times))
        self.write_on_finalize = write_on_finalize

    def handle(self, field, t: float) -> None:
        self.record(t, field.data)

    def finalize(self, info=None) -> None:
        TrackerBase.finalize(self, info)
        controller = (info or {}).get("controller", {})
        if controller.get("successful") is False and controller.get("state_data") is not None:
            self.failed(controller["t_final"], controller["state_data"], controller.get("stop_reason", "failed"))
        if self.write_on_finalize:
            self.write()
