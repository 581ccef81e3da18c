"""py-pde trackers for shear-cell runs.

Snapshots use py-pde's ``MemoryStorage``/``FileStorage`` trackers. The trackers here
record the derived quantities the paper plots, max|w|(t) (figs 4a, 6b, 7e) and chi of
(A18) (figs 2d, 7d), and show a run while it evolves: a tqdm.auto progress bar with a
compiling phase and an honest end (:class:`ProgressBarTracker`), and one live figure
updated in place at a bounded cost (:class:`LivePlotTracker`). Movies:
:mod:`icidr_pde.movies`.

All follow py-pde's tracker conventions (``initialize(field, info)``, ``handle(field,
t)``, ``finalize(info)`` with ``info["controller"]``); a failed run reaches
``finalize`` with ``successful=False``, ``t_final`` = t*, ``stop_reason`` and
``state_data`` (the state at t*).
"""

from __future__ import annotations

import time

import numpy as np
from pde.trackers.base import TrackerBase

from .progress import TimeBar, in_jupyter
from .times import dense_times

__all__ = ["MaxWTracker", "ChiTracker", "ProgressBarTracker", "LivePlotTracker", "dense_times"]


class MaxWTracker(TrackerBase):
    """Record max|w|(t), the maximum over the nodes, at the interrupts.

    Given a list of times, the tracker can instead be recorded by the stiff solver inside
    its stepping loop (:meth:`icidr_pde.engines.stiff.StiffSolver.record` with `times` and
    :meth:`record`, as :func:`icidr_pde.api.integrate` does): the same numbers at the same
    times, without one py-pde interrupt per time.

    Args:
        interrupts: when to record (py-pde interrupt data, e.g. a list of times)
    """

    name = "max_w"

    def __init__(self, interrupts=1):
        super().__init__(interrupts=interrupts)
        self.times: list[float] = []
        self.values: list[float] = []
        listed = np.iterable(interrupts) and not isinstance(interrupts, str)
        #: the times as a sorted array where they were given as a list, else None
        self.series_times = np.sort(np.asarray(interrupts, dtype=float)) if listed else None

    def handle(self, field, t: float) -> None:
        self.record(t, field.data)

    def record(self, t: float, data: np.ndarray) -> None:
        """Record max|w| of the state `data` (fields first) at time t."""
        self.times.append(float(t))
        self.values.append(float(np.max(np.abs(data[2]))))


class ChiTracker(TrackerBase):
    """Record chi of (A18) where the stresses are evaluated (chi > 0: mu(I) ill-posed).

    Args:
        pde: the shear-cell PDE (supplies the strain rates of its discretization)
        interrupts: when to record
    """

    name = "chi"

    def __init__(self, pde, interrupts=1):
        super().__init__(interrupts=interrupts)
        self.pde = pde
        self.times: list[float] = []
        self.z: np.ndarray | None = None
        self.values: list[np.ndarray] = []

    def handle(self, field, t: float) -> None:
        with np.errstate(all="ignore"):  # a state overflowing the strain rates has chi = inf or nan
            z, phi, uz, wz = self.pde.strain_rates(field.data, field.grid)
            self.values.append(self.pde.rheology.chi(phi, uz, wz))
        self.z = z
        self.times.append(float(t))


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


class LivePlotTracker(TrackerBase):
    """One figure updated in place while a run evolves: phi, u, w against z, max|w|(t),
    and chi (A18) where a function for it is given (the mu(I) runs).

    In Jupyter the figure is one rich output, replaced at every redraw
    (``IPython.display`` with a ``display_id``), so an executed notebook keeps exactly
    one live figure per run; with an interactive matplotlib backend it is a window; with
    a non-interactive backend it is drawn only into `output_file` (if given).

    Cost is bounded by wall-clock budget, not by a fixed count: after a redraw that took
    d seconds the next redraw waits until (1/max_overhead - 1) d seconds have passed,
    so redrawing costs at most about `max_overhead` of the run's wall time (default
    10 %) plus a fixed cost per run: creating the figure and drawing the first and the
    final state (always drawn), ~0.1-0.3 s each on one core. All of it is in `overhead_s`.

    Args:
        z: positions of the unknowns (the discretization's nodes)
        t_end: final time (sets the time axis and the default interrupts)
        interrupts: when to consider a redraw (default: log-spaced plus uniform times)
        chi: optional function(state_data) -> (z_chi, chi) for the chi panel
        max_overhead: fraction of wall time redrawing may take
        title: text before the time in the title
        output_file: image refreshed at every redraw (e.g. to watch a remote run)
        show: None: automatic (Jupyter or an interactive backend); False: only files
    """

    name = "shear_live_plot"
    fields = ("phi", "u", "w")

    def __init__(self, z, t_end: float, interrupts=None, *, chi=None, max_overhead: float = 0.1,
                 title: str = "", output_file=None, show: bool | None = None):
        if not 0 < max_overhead < 1:
            raise ValueError(f"`max_overhead` must lie in (0, 1); got {max_overhead}")
        if interrupts is None:
            interrupts = list(dense_times(t_end, n_log=60, n_lin=200))
        super().__init__(interrupts=interrupts)
        self.z = np.asarray(z, dtype=float)
        self.t_end = float(t_end)
        self._t_range = (dense_times(self.t_end)[1], self.t_end)  # the first time after 0 to t_end
        self.chi = chi
        self.max_overhead = max_overhead
        self.title = title
        self.output_file = output_file
        self.show = show
        self.times: list[float] = []
        self.max_w: list[float] = []
        self.n_draws = 0
        self.overhead_s = 0.0
        self.fig = None
        self._mode = "none"
        self._handle = None
        self._next_draw = 0.0
        self._last = None

    # -- figure ---------------------------------------------------------------------------
    def _make_figure(self):
        import matplotlib
        from matplotlib.ticker import LogFormatter

        interactive = matplotlib.get_backend().lower() not in {
            "agg", "pdf", "ps", "svg", "cairo", "template", "module://matplotlib_inline.backend_inline"}
        if self.show is not False and in_jupyter():
            self._mode = "jupyter"
        elif self.show is not False and interactive:
            self._mode = "window"
        else:
            self._mode = "none"
        if self._mode == "window":
            import matplotlib.pyplot as plt

            fig = plt.figure(figsize=(12, 3.2))
        else:  # not registered with pyplot: Jupyter shows it only through our display handle
            from matplotlib.figure import Figure

            fig = Figure(figsize=(12, 3.2), dpi=72)  # each redraw is a PNG: small and quick
        n = 5 if self.chi is not None else 4
        axes = fig.subplots(1, n)
        self._lines = {}
        for ax, name in zip(axes, self.fields):
            (self._lines[name],) = ax.plot(self.z, np.zeros_like(self.z), color="k")
            ax.set_xlabel("z")
            ax.set_ylabel(name)
        ax = axes[3]  # log t: a mu(I) blow-up at t ~ 1e-2 of t_end = 10 is visible (t = 0 is not drawn)
        (self._lines["max_w"],) = ax.loglog([], [], color="tab:red")
        for axis in (ax.xaxis, ax.yaxis):  # plain "1e-2" labels: narrower and quicker than mathtext
            axis.set_major_formatter(LogFormatter(labelOnlyBase=True))
            axis.set_minor_formatter(LogFormatter(labelOnlyBase=True))
        ax.set_xlabel("t")
        ax.set_ylabel("max|w|")
        ax.set_xlim(*self._t_range)
        if self.chi is not None:
            ax = axes[4]
            (self._lines["chi"],) = ax.plot([], [], color="tab:purple")
            ax.axhline(0, color="gray", lw=0.6)
            ax.set_xlabel("z")
            ax.set_ylabel(r"$\chi$ (A18)")
        self._axes = axes
        self._suptitle = fig.suptitle(self.title, fontsize=10)
        # fixed (no re-layout per redraw), wide enough for tick labels of the form -0.0005 and 1e-10
        fig.subplots_adjust(left=0.06, right=0.99, bottom=0.17, top=0.85, wspace=0.6)
        return fig

    def _draw(self, data, t: float, status: str = "") -> None:
        start = time.perf_counter()
        for k, name in enumerate(self.fields):
            self._lines[name].set_ydata(data[k])
        self._lines["max_w"].set_data(self.times, self.max_w)
        if self.chi is not None:
            z_chi, chi = self.chi(data)
            self._lines["chi"].set_data(z_chi, np.clip(chi, -5, 5))  # +inf where u_z = 0 < w_z
        for ax in self._axes:
            ax.relim()
            ax.autoscale_view()
        self._axes[3].set_xlim(*self._t_range)
        self._suptitle.set_text(f"{self.title}  t = {t:.5g}{status}")
        if self._mode == "jupyter":
            if self._handle is None:
                from IPython.display import display

                self._handle = display(self.fig, display_id=True)
            else:
                self._handle.update(self.fig)
        elif self._mode == "window":
            self.fig.canvas.draw_idle()
            self.fig.canvas.flush_events()
        if self.output_file:  # whole at every redraw: a watcher never reads half an image
            from .outputs import save_figure

            save_figure(self.fig, self.output_file)
        cost = time.perf_counter() - start
        self.n_draws += 1
        self.overhead_s += cost
        self._next_draw = time.perf_counter() + cost * (1 / self.max_overhead - 1)

    # -- tracker protocol -----------------------------------------------------------------
    def initialize(self, field, info=None) -> float:
        start = time.perf_counter()
        self.fig = self._make_figure()
        self.overhead_s += time.perf_counter() - start
        if self._mode == "window":
            import matplotlib.pyplot as plt

            plt.show(block=False)
        return super().initialize(field, info)

    def handle(self, field, t: float) -> None:
        data = field.data
        self.times.append(float(t))
        self.max_w.append(float(np.max(np.abs(data[2]))))
        self._last = (data.copy(), float(t))
        if time.perf_counter() >= self._next_draw:
            self._draw(data, t)

    def finalize(self, info=None) -> None:
        super().finalize(info)
        controller = (info or {}).get("controller", {})
        state = controller.get("state_data")
        t = controller.get("t_final")
        if state is not None and t is not None:  # a failed run hands over the state at t*
            self.times.append(float(t))
            self.max_w.append(float(np.max(np.abs(state[2]))))
            self._last = (np.asarray(state), float(t))
        if self._last is None or self.fig is None:
            return
        data, t = self._last
        status = ""
        if controller.get("successful") is False:
            status = f": FAILED ({controller.get('stop_reason', 'stopped early')})"
        self._draw(data, t, status)
