"""One live figure of a 1-D run, updated in place at a bounded cost: py-pde-free.

:class:`LivePlot` is a recorder of the run path (:func:`icidr_pde.api.run` with
``live_plot=True`` calls it at its output times).
"""

from __future__ import annotations

import time

import numpy as np

from .progress import in_jupyter
from .times import dense_times

__all__ = ["LivePlot"]


class LivePlot:
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
    final state (always drawn; measured in docs/performance.md, Live figure overhead). All of
    it is in `overhead_s`.

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

    fields = ("phi", "u", "w")

    def __init__(self, z, t_end: float, interrupts=None, *, chi=None, max_overhead: float = 0.1,
                 title: str = "", output_file=None, show: bool | None = None):
        if not 0 < max_overhead < 1:
            raise ValueError(f"`max_overhead` must lie in (0, 1); got {max_overhead}")
        #: when to consider a redraw (a recorder's output times)
        self.output_times = dense_times(t_end, n_log=60, n_lin=200) if interrupts is None else interrupts
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

    # -- recorder ---------------------------------------------------------------------------
    def start(self) -> None:
        """Create the figure (a window is shown at once)."""
        start = time.perf_counter()
        self.fig = self._make_figure()
        self.overhead_s += time.perf_counter() - start
        if self._mode == "window":
            import matplotlib.pyplot as plt

            plt.show(block=False)

    def record(self, t: float, data) -> None:
        """The state `data` (fields first) at time t: redrawn if the budget allows."""
        if self.fig is None:
            self.start()
        self.times.append(float(t))
        self.max_w.append(float(np.max(np.abs(data[2]))))
        self._last = (np.array(data, copy=True), float(t))
        if time.perf_counter() >= self._next_draw:
            self._draw(data, t)

    def finish(self, t=None, data=None, failed: str | None = None) -> None:
        """Draw the last state; a failed run hands over the state at t* (`t`, `data`) and why."""
        if data is not None and t is not None:
            self.times.append(float(t))
            self.max_w.append(float(np.max(np.abs(data[2]))))
            self._last = (np.asarray(data), float(t))
        if self._last is None or self.fig is None:
            return
        data, t = self._last
        self._draw(data, t, f": FAILED ({failed})" if failed is not None else "")

    def close(self, outcome) -> None:
        """The end of a run of :func:`icidr_pde.api.run` (its Outcome)."""
        if outcome.blew_up:
            self.finish(outcome.t_final, outcome.final, outcome.reason)
        else:
            self.finish()

    def abandon(self) -> None:
        pass
