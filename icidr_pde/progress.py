"""The progress bar of a run over simulated time, one for both engines.

:class:`TimeBar` is a tqdm bar whose description is the run's phase: "compiling" while
the stepper is built, "integrating" (with the build time), then "done", "FAILED at t* = ..."
or "interrupted at t = ...", the bar left at the time reached. The run path's one loop
drives it for every engine (:func:`icidr_pde.api.run`). tqdm only: importing this module imports
neither py-pde nor IPython.
"""

from __future__ import annotations

import sys

__all__ = ["TimeBar", "in_jupyter"]

#: while running: the time reached, of t_end, and the elapsed and remaining wall time (the time is
#: the bar's own count: tqdm's {postfix} would come with a ", " in front)
RUNNING_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} [{elapsed}<{remaining}]"
#: once ended: no estimate of a remaining time
ENDED_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} [{elapsed}]"
#: longest failure reason shown in the bar (the Result holds all of it)
REASON_CHARS = 60


def in_jupyter() -> bool:
    """True inside a Jupyter kernel (where figures and bars are shown as rich outputs)."""
    if "IPython" not in sys.modules:  # a kernel has imported it; a script need not
        return False
    shell = sys.modules["IPython"].get_ipython()
    return shell is not None and "IPKernelApp" in getattr(shell, "config", {})


def _tqdm():
    if in_jupyter():
        from tqdm.auto import tqdm
    else:  # tqdm.auto would import asyncio: slow for a warm command line
        from tqdm import tqdm
    return tqdm


def short_reason(reason: str) -> str:
    """The head of a failure reason, for one line: before its first parenthesis, at most
    :data:`REASON_CHARS` characters."""
    head = reason.split(" (")[0].strip() or reason
    return head if len(head) <= REASON_CHARS else head[:REASON_CHARS - 1] + "…"


def _describe(phase: str, note: str) -> str:
    return f"{phase} ({note})" if note else phase


class TimeBar:
    """A tqdm bar over simulated time 0..`t_end` whose description is the run's phase.

    Args:
        t_end: final time
        phase: the phase to start with: "compiling" where a stepper is built next, else "integrating"
        note: said after the phase, e.g. the engine
        file: stream of the text bar (default sys.stderr)
        log_interval: seconds between updates when the output is not a terminal
    """

    def __init__(self, t_end: float, phase: str = "compiling", note: str = "", *, file=None,
                 log_interval: float = 30.0):
        stream = file if file is not None else sys.stderr
        self.terminal = in_jupyter() or getattr(stream, "isatty", lambda: False)()
        self.t_end = float(t_end)
        self.phase = phase
        self.bar = _tqdm()(total=self.t_end, initial=0.0, file=file, leave=True, desc=_describe(phase, note),
                           mininterval=0.1 if self.terminal else log_interval, bar_format=RUNNING_FORMAT)

    def integrating(self, note: str = "") -> None:
        """The stepper is built: restart the rate and ETA so that they count integration only."""
        self.phase = "integrating"
        self.bar.set_description_str(_describe(self.phase, note), refresh=False)
        self.bar.reset(total=self.t_end)

    def advance(self, t: float) -> None:
        """The run has reached time `t` (refreshes at most every mininterval)."""
        self.bar.update(min(float(t), self.t_end) - self.bar.n)

    def discard(self) -> None:
        """The run did not start (its set-up raised): the bar goes, leaving no line."""
        self.bar.leave = False
        self.bar.close()

    def close(self, t_final: float, outcome: str = "done", reason: str = "") -> None:
        """End the bar at the time reached `t_final` with its `outcome`: "done" (at t_end),
        "failed" (a blow-up at t* = t_final, red in Jupyter), "interrupted" (Ctrl-C) or
        "stopped" (a tracker ended the run, e.g. a wall-clock limit); `reason` says why."""
        why = f" ({short_reason(reason)})" if reason else ""
        texts = {"done": "done", "failed": f"FAILED at t* = {t_final:.5g}{why}",
                 "interrupted": f"interrupted at t = {t_final:.5g}", "stopped": f"stopped at t = {t_final:.5g}{why}"}
        self.phase = outcome
        if outcome == "done":
            t_final = self.t_end
        if outcome == "failed" and self.terminal:  # no escape codes in a log file
            try:
                self.bar.colour = "red"
            except Exception:  # colour is cosmetic; older tqdm lacks it on some bars
                pass
        self.bar.n = min(float(t_final), self.t_end)
        self.bar.bar_format = ENDED_FORMAT
        self.bar.set_description_str(texts[outcome], refresh=False)
        self.bar.refresh()
        self.bar.close()
