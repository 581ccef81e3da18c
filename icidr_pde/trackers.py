"""py-pde trackers that show a shear-cell run of ``eq.solve(state, tracker=...)`` while it
evolves: a tqdm.auto progress bar with a compiling phase and an honest end
(:class:`ProgressBarTracker`), and one live figure updated in place at a bounded cost
(:class:`LivePlotTracker`, over :class:`icidr_pde.live_plot.LivePlot`). Movies:
:class:`icidr_pde.movies.tracker.MovieTracker`. ``icidr_pde.run`` takes none of them: its
recorders are called by its own loop (:func:`icidr_pde.api.make_recorders`).

All follow py-pde's tracker conventions (``initialize(field, info)``, ``handle(field,
t)``, ``finalize(info)`` with ``info["controller"]``); a failed run reaches
``finalize`` with ``successful=False``, ``t_final`` = t*, ``stop_reason`` and
``state_data`` (the state at t*).
"""

from __future__ import annotations

import time

from pde.trackers.base import TrackerBase

from .live_plot import LivePlot
from .progress import TimeBar
from .times import dense_times

__all__ = ["ProgressBarTracker", "LivePlotTracker"]


class ProgressBarTracker(TrackerBase):
    """Progress of a run as a :class:`~icidr_pde.progress.TimeBar` over simulated time (a widget in Jupyter,
    one line in a terminal, a few lines in a log file).

    Phases: "compiling" from initialisation until the first step (py-pde initialises
    the trackers before the solver builds, and numba compiles, its stepper), then
    "integrating"; the rate and ETA restart when integration starts, so compile time does
    not distort them. A run that fails is left where it failed: the bar stops at t*
    (not 100 %) and its description says why; in Jupyter it turns red.

    Args:
        interrupts: when to update (py-pde interrupt data); default: every 1/200 of t_end
            once `t_end` is known, log-spaced early on so that failures near t ~ 1e-2
            still move the bar
        t_end: final time (default: from the controller's info)
        log_interval: seconds between updates when the output is not a terminal
        file: stream of the text bar (default sys.stderr)

    `finalize(info)` follows py-pde: ``info["controller"]`` carries ``t_final``,
    ``successful`` and ``stop_reason``.
    """

    name = "shear_progress"

    def __init__(self, interrupts=None, *, t_end: float | None = None, log_interval: float = 30.0,
                 file=None):
        if interrupts is None:
            if t_end is None:
                raise ValueError("`t_end` is required when `interrupts` is None")
            interrupts = list(dense_times(t_end, n_log=40, n_lin=200))
        super().__init__(interrupts=interrupts)
        self.t_end = t_end
        self.log_interval = log_interval
        self.file = file
        self.time_bar: TimeBar | None = None
        self.bar = None  # the tqdm bar
        self.compile_s: float | None = None
        self._info: dict = {}
        self._t_last = 0.0

    def initialize(self, field, info=None) -> float:
        result = super().initialize(field, info)
        self._info = info or {}
        controller = self._info.get("controller", {})
        self.t_end = float(self.t_end if self.t_end is not None else controller.get("t_end", 1.0))
        self.time_bar = TimeBar(self.t_end, "compiling", file=self.file, log_interval=self.log_interval)
        self.bar = self.time_bar.bar
        self._t_compile = time.perf_counter()
        return result

    @property
    def phase(self) -> str:
        return self.time_bar.phase if self.time_bar is not None else "created"

    def handle(self, field, t: float) -> None:
        if self.phase == "compiling":
            solver_info = self._info.get("solver", {})
            self.compile_s = solver_info.get("compile_s", time.perf_counter() - self._t_compile)
            self.time_bar.integrating(f"compiled in {self.compile_s:.1f} s")
        self._t_last = float(t)
        self.time_bar.advance(t)

    def finalize(self, info=None) -> None:
        super().finalize(info)
        if self.time_bar is None:
            return
        controller = (info or {}).get("controller", {})
        t_final = float(controller.get("t_final", self._t_last))
        reached = t_final >= self.t_end * (1 - 1e-9)
        reason = controller.get("stop_reason", "stopped early")
        if controller.get("successful", reached):
            outcome = "done" if reached else "stopped"  # a tracker ended it early (FinishedSimulation)
        else:
            outcome = "interrupted" if "interrupted" in reason else "failed"
        self.time_bar.close(t_final, outcome, "" if outcome == "done" else reason)


class LivePlotTracker(LivePlot, TrackerBase):
    """py-pde's tracker of the live figure :class:`~icidr_pde.live_plot.LivePlot` (same arguments)."""

    name = "shear_live_plot"

    def __init__(self, z, t_end: float, interrupts=None, **kwargs):
        LivePlot.__init__(self, z, t_end, interrupts, **kwargs)
        TrackerBase.__init__(self, interrupts=list(self.output_times) if interrupts is None else interrupts)

    def initialize(self, field, info=None) -> float:
        self.start()
        return TrackerBase.initialize(self, field, info)

    def handle(self, field, t: float) -> None:
        self.record(t, field.data)

    def finalize(self, info=None) -> None:
        TrackerBase.finalize(self, info)
        controller = (info or {}).get("controller", {})
        failed = controller.get("stop_reason", "stopped early") if controller.get("successful") is False else None
        self.finish(controller.get("t_final"), controller.get("state_data"), failed)
