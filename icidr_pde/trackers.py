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

import sys
import time

import numpy as np
from pde.trackers.base import TrackerBase

from .times import dense_times

__all__ = ["MaxWTracker", "ChiTracker", "ProgressBarTracker", "LivePlotTracker", "dense_times"]


class MaxWTracker(TrackerBase):
    """Record max|w|(t), the maximum over the nodes, at the interrupts.

    Given a list of times, the tracker can instead be recorded by the stiff solver inside
    its stepping loop (:meth:`icidr_pde.integrator.StiffSolver.record` with `times` and
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


def _in_jupyter() -> bool:
    """True inside a Jupyter kernel (where figures are shown as rich outputs)."""
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


class ProgressBarTracker(TrackerBase):
    """Progress of a run as a tqdm.auto bar over simulated time (a widget in Jupyter,
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
        self.bar = None
        self.phase = "created"
        self.compile_s: float | None = None
        self._info: dict = {}
        self._t_last = 0.0

    def initialize(self, field, info=None) -> float:
        from tqdm.auto import tqdm

        result = super().initialize(field, info)
        self._info = info or {}
        controller = self._info.get("controller", {})
        self.t_end = float(self.t_end if self.t_end is not None else controller.get("t_end", 1.0))
        stream = self.file if self.file is not None else sys.stderr
        terminal = _in_jupyter() or getattr(stream, "isatty", lambda: False)()
        self.bar = tqdm(total=self.t_end, initial=0.0, file=self.file, leave=True,
                        mininterval=0.1 if terminal else self.log_interval,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {postfix} [{elapsed}<{remaining}]")
        self.bar.set_description_str("compiling", refresh=False)
        self.bar.set_postfix_str(f"0/{self.t_end:g}")
        self.phase = "compiling"
        self._t_compile = time.perf_counter()
        return result

    def handle(self, field, t: float) -> None:
        if self.phase == "compiling":
            solver_info = self._info.get("solver", {})
            self.compile_s = solver_info.get("compile_s", time.perf_counter() - self._t_compile)
            self.phase = "integrating"
            self.bar.reset(total=self.t_end)  # rate and ETA count integration only
            self.bar.set_description_str(f"integrating (compiled in {self.compile_s:.1f} s)", refresh=False)
        self._t_last = float(t)
        self.bar.n = min(float(t), self.t_end)
        self.bar.set_postfix_str(f"{t:.4g}/{self.t_end:g}")  # refreshes at most every mininterval

    def finalize(self, info=None) -> None:
        super().finalize(info)
        if self.bar is None:
            return
        controller = (info or {}).get("controller", {})
        t_final = float(controller.get("t_final", self._t_last))
        successful = controller.get("successful", t_final >= self.t_end * (1 - 1e-9))
        if successful:
            self.phase = "done"
            self.bar.n = self.t_end
            self.bar.set_description_str("done", refresh=False)
        else:
            self.phase = "failed"
            reason = controller.get("stop_reason", "stopped early")
            self.bar.n = min(t_final, self.t_end)
            self.bar.set_description_str(f"FAILED at t* = {t_final:.5g}: {reason}", refresh=False)
            try:
                self.bar.colour = "red"
            except Exception:  # colour is cosmetic; older tqdm lacks it on some bars
                pass
        self.bar.set_postfix_str(f"{min(t_final, self.t_end):.4g}/{self.t_end:g}", refresh=False)
        self.bar.refresh()
        self.bar.close()


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

        interactive = matplotlib.get_backend().lower() not in {
            "agg", "pdf", "ps", "svg", "cairo", "template", "module://matplotlib_inline.backend_inline"}
        if self.show is not False and _in_jupyter():
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
        ax = axes[3]
        (self._lines["max_w"],) = ax.semilogy([], [], color="tab:red")
        ax.set_xlabel("t")
        ax.set_ylabel("max|w|")
        ax.set_xlim(0, self.t_end)
        if self.chi is not None:
            ax = axes[4]
            (self._lines["chi"],) = ax.plot([], [], color="tab:purple")
            ax.axhline(0, color="gray", lw=0.6)
            ax.set_xlabel("z")
            ax.set_ylabel(r"$\chi$ (A18)")
        self._axes = axes
        self._suptitle = fig.suptitle(self.title, fontsize=10)
        fig.subplots_adjust(left=0.05, right=0.99, bottom=0.17, top=0.85, wspace=0.4)  # fixed: no re-layout
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
        self._axes[3].set_xlim(0, self.t_end)
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
        if self.output_file:
            self.fig.savefig(self.output_file)
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
