"""The drive loop: one engine advanced through the outputs of a run, the recorders called there.

:func:`drive` merges the schedule (:mod:`icidr_pde.schedule`) and the recorders' times
(:mod:`icidr_pde.recorders`) into one list of outputs (:class:`Outputs`), advances the engine
through them chunk by chunk with ``Engine.advance_outputs`` (the native engine: many outputs per
call into C, no Python per step), calls the recorders after each chunk (:class:`Recording`) and
stops at a failure, a recorder's :class:`~icidr_pde.recorders.StopRun` or Ctrl-C. What it
reached becomes the run's :class:`Outcome` (:func:`outcome`) and :class:`Recorded`
(:func:`recorded`). It sees the engine's state vectors through a :class:`View`, the same for
every engine.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field

import numpy as np

from .recorders import StopRun
from .schedule import Schedule
from .times import merged_output_times
from .validation import nonfinite_rates

__all__ = ["View", "Outputs", "Recording", "Outcome", "Recorded", "drive", "outcome", "recorded", "LAST_STATES"]

#: output times per call into C, adapted to take 0.02-0.1 s a call: Ctrl-C and the progress bar
#: act between calls, and a call's Python is small beside that
CHUNK = (8, 1, 1024)  # first, smallest, largest

#: states kept at the last max|w| series times before the end of a run (Result.last_states)
LAST_STATES = 6


class View:
    """The run path's view of a case on an engine: the engine's initial vector `y0` (its
    Problem's), the fields (3, ...) of an engine vector (`fields`), the rates' fields of a vector
    (`rates`, for the initial check), the chi of (A18) of the fields (`chi`: (positions, chi)) and
    the Problem's check of a vector."""

    #: whether this process holds the whole states (all but the ranks other than 0 of a run
    #: distributed by blocks, :func:`icidr_pde.api._blocks_set_up`)
    root = True

    def __init__(self, case, problem, fields, rates, chi):
        self.case, self.problem, self.fields, self.rates, self.chi = case, problem, fields, rates, chi
        self.scene, self.N, self.y0 = case.scene, case.N, problem.y0

    def shared(self, result):
        """The Result this process returns of the Result of its run (the same)."""
        return result

    def initial_reason(self) -> str | None:
        invalid = self.problem.check(self.y0)
        if invalid:
            return f"initial state invalid: {invalid}"
        with np.errstate(all="ignore"):
            return nonfinite_rates(self.rates(self.y0), 0.0)

    def max_abs_w(self, y) -> float:
        return float(np.max(np.abs(self.fields(y)[2])))


@dataclass
class Outcome:
    """How an integration ended."""

    final: np.ndarray
    blew_up: bool
    t_star: float | None
    reason: str
    t_final: float
    wall_s: float
    compile_s: float
    cpu_s: float | None = None  # CPU time of the solve (this process), set-up excluded


@dataclass
class Outputs:
    """The schedule of a run as output indices: merged times, where each list's times are
    (`at_recorders`: one array per recorder), which outputs keep their state (store[k] >= 0:
    the snapshots, chi samples and the last for the whole run, a recorder's only until it has
    been called, in a ring of slots) and the arrays the engine writes."""

    times: np.ndarray
    at_series: np.ndarray
    at_snap: np.ndarray
    at_chi: np.ndarray
    store: np.ndarray
    states: np.ndarray
    max_w: np.ndarray
    at_recorders: list = field(default_factory=list)
    at_last: np.ndarray = field(default_factory=lambda: np.empty(0, int))

    @classmethod
    def of(cls, sched: Schedule, t_end: float, n: int, recorders=()) -> "Outputs":
        lists = [sched.series, sched.snap_times, sched.chi_times] + [r.output_times for r in recorders]
        times, (at_series, at_snap, at_chi, *at_recorders) = merged_output_times(t_end, lists)
        kept = np.unique(np.concatenate([at_snap, at_chi, [times.size - 1]]).astype(int))
        kept = kept[kept >= 0]
        store = np.full(times.size, -1, dtype=np.intc)
        store[kept] = np.arange(kept.size)
        passing = np.unique(np.concatenate([np.asarray(at, int) for at in at_recorders] or [np.empty(0, int)]))
        passing = np.setdiff1d(passing[passing >= 0], kept)
        ring = min(CHUNK[2], passing.size)  # a chunk holds at most CHUNK[2] consecutive outputs
        if ring:
            store[passing] = kept.size + np.arange(passing.size) % ring
        # the series' other states cycle through LAST_STATES slots: the last ones before the
        # end (a failure's t*) stay, to be drawn (only read once the run has ended)
        at_last = np.setdiff1d(np.unique(np.asarray(at_series, int)), np.concatenate([kept, passing]))
        at_last = at_last[at_last >= 0]
        last = min(LAST_STATES, at_last.size)
        if last:
            store[at_last] = kept.size + ring + np.arange(at_last.size) % last
        return cls(times, at_series, at_snap, at_chi, store, np.empty((max(kept.size + ring + last, 1), n)),
                   np.full(times.size, np.nan), at_recorders, at_last)


class Recording:
    """Calls the recorders at their outputs in time order (at one output, in the order given),
    with the fields of the state there; a recorder's StopRun ends the run at that output."""

    def __init__(self, recorders, out: Outputs, view: View):
        self.recorders, self.out, self.view = list(recorders), out, view
        events = sorted((int(i), order) for order, at in enumerate(out.at_recorders) for i in np.unique(at))
        self.events, self.next = events, 0
        self.stop: tuple[int, str, float] | None = None  # (output index, reason, time)

    def through(self, n_done: int) -> int:
        """Record every output before `n_done`; returns the outputs the run keeps (fewer on a stop)."""
        out, fields = self.out, self.view.fields
        while self.next < len(self.events) and self.events[self.next][0] < n_done and self.stop is None:
            index, order = self.events[self.next]
            self.next += 1  # first: a Ctrl-C inside a recorder does not call it twice
            y = self.view.y0 if index < 0 else out.states[out.store[index]]
            t = 0.0 if index < 0 else float(out.times[index])
            try:
                self.recorders[order].record(t, fields(y))
            except StopRun as stop:
                self.stop = (index, str(stop), t)
        return n_done if self.stop is None else self.stop[0] + 1

    def close(self, outcome) -> None:
        for recorder in self.recorders:
            recorder.close(outcome)

    def abandon(self) -> None:
        for recorder in self.recorders:
            recorder.abandon()


def drive(view: View, make_engine, sched: Schedule, t_end: float, bar, recorders=()):
    """Integrate from the view's y0 through the schedule and the recorders' output times,
    calling the recorders there: (outputs, outputs done, failure, engine, recording), where
    recording.stop is None or (output index, reason, time) of a recorder that ended the run. The
    recorders are abandoned if this raises (a snapshot file leaves the target as it was); the
    caller closes them with the Outcome."""
    out, y0 = Outputs.of(sched, t_end, view.y0.size, recorders), view.y0
    recording = Recording(recorders, out, view)
    engine, n_done, failure = None, 0, None
    try:
        recording.through(0)  # the recorders' times at t = 0
        reason0 = view.initial_reason()
        if reason0:
            failure = (0.0, y0.copy(), reason0)
        else:
            engine = make_engine()
            n_done, failure = _advance(engine, out, bar, view.max_abs_w, recording)
    except KeyboardInterrupt:  # before the engine started: nothing computed past t = 0
        engine = None
    except BaseException:
        recording.abandon()
        raise
    finally:
        if bar is not None:
            last_output = float(out.times[n_done - 1]) if n_done else 0.0
            _close_bar(bar, failure, n_done < out.times.size, engine, t_end, recording.stop, last_output)
    return out, n_done, failure, engine, recording


def _advance(engine, out: Outputs, bar, measure, recording: Recording):
    """Advance the engine through every output, chunk by chunk (the native engine: no Python
    per step), calling the recorders after each chunk. Returns (outputs done, failure or None);
    a KeyboardInterrupt ends it where the engine stopped, a recorder's StopRun at its output."""
    n_done, n_out, failure = 0, out.times.size, None
    size, smallest, largest = CHUNK
    try:
        while n_done < n_out and failure is None and recording.stop is None:
            chunk = slice(n_done, min(n_done + size, n_out))
            call = _time.perf_counter()
            done, failure = engine.advance_outputs(out.times[chunk], out.store[chunk], out.max_w[n_done:], out.states,
                                                   measure)
            call = _time.perf_counter() - call
            size = min(2 * size, largest) if call < 0.02 else max(size // 2, smallest) if call > 0.1 else size
            n_done = recording.through(n_done + done)
            if bar is not None and n_done:
                bar.advance(out.times[n_done - 1])
    except KeyboardInterrupt:
        n_done = _outputs_reached(engine, out, n_done)
        try:
            n_done = recording.through(n_done)
        except KeyboardInterrupt:  # a second Ctrl-C: the recorders keep what they have
            pass
    return n_done, failure


def _outputs_reached(engine, out: Outputs, n_done: int) -> int:
    """Outputs done when Ctrl-C came: the signal is seen only once the engine has returned,
    possibly before Python counted the outputs of that call (written, and the last kept)."""
    reached = int(np.searchsorted(out.times, engine.last_good()[0], side="right"))
    while reached > n_done and not np.isfinite(out.max_w[reached - 1]):  # stopped on an invalid state
        reached -= 1
    return max(n_done, reached)


def _close_bar(bar, failure, interrupted, engine, t_end, stop=None, last_output=0.0):
    if failure is not None:
        bar.close(failure[0], "failed", failure[2])
    elif stop is not None:  # a recorder ended the run (the wall-clock limit)
        bar.close(stop[2], "stopped", stop[1])
    elif interrupted:  # the time outcome() reports
        t = engine.last_step_time() if engine is not None else 0.0
        bar.close(t if t <= t_end else last_output, "interrupted")
    else:
        bar.close(t_end)


def outcome(view: View, engine, out: Outputs, n_done, failure, t_end, wall, compile_s, cpu, stop=None) -> Outcome:
    """How the run ended: failed (the state at t*), stopped by a recorder, interrupted (the time and
    state of the engine's last accepted step, ``Engine.last_step``: past the last output, which may
    be hours of steps earlier), or at t_end."""
    if failure is not None:
        t_final, final = failure[0], view.fields(failure[1])
        return Outcome(final, True, float(t_final), failure[2], float(t_final), wall, compile_s, cpu)
    if stop is not None:  # a recorder ended the run at an output (its state is still kept)
        index, reason, t_final = stop
        y = view.y0 if index < 0 else out.states[out.store[index]]
        return Outcome(view.fields(y), False, None, reason, t_final, wall, compile_s, cpu)
    if n_done < out.times.size:  # interrupted: the state of the engine's last accepted step
        t_final, y_last = engine.last_step() if engine is not None else (0.0, view.y0)
        if t_final > t_end:  # a step over t_end, its output not written: the last output's, before t_end
            t_final, y_last = engine.last_good()
        return Outcome(view.fields(y_last), False, None, f"interrupted at t = {t_final:.6g}", float(t_final),
                       wall, compile_s, cpu)
    final = view.fields(out.states[out.store[-1]])
    return Outcome(final, False, None, "reached t_end", float(t_end), wall, compile_s, cpu)


@dataclass
class Recorded:
    """What a run recorded, whichever engine ran it: the snapshots done (`times`, `data`
    (n, 3, N)), the max|w| series (None: not recorded) and the chi samples (chi_t empty: none)."""

    times: np.ndarray
    data: np.ndarray
    max_w_t: list | None
    max_w: list | None
    chi_t: np.ndarray = field(default_factory=lambda: np.empty(0))
    chi_z: np.ndarray | None = None
    chi: np.ndarray | None = None
    last_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    last_states: np.ndarray | None = None


def recorded(view: View, sched: Schedule, out: Outputs, n_done: int) -> Recorded:
    """Snapshots, series and chi of the outputs a run reached."""
    y0, fields = view.y0, view.fields

    def state_at(index):
        return y0 if index < 0 else out.states[out.store[index]]

    # one snapshot per distinct time, labelled by the first labels (as py-pde's storage records them)
    snap = sched.snap_times
    snaps = [k for k, i in enumerate(out.at_snap) if i < n_done and (k == 0 or snap[k] > snap[k - 1])]
    shape = fields(y0).shape
    data = np.array([fields(state_at(out.at_snap[k])) for k in snaps]).reshape(len(snaps), *shape)
    result = Recorded(snap[snaps], data, None, None)
    if sched.series.size:
        done = [k for k, i in enumerate(out.at_series) if i < n_done]
        result.max_w_t = [float(out.times[out.at_series[k]]) if out.at_series[k] >= 0 else float(sched.series[k])
                          for k in done]
        result.max_w = [float(out.max_w[out.at_series[k]]) if out.at_series[k] >= 0
                        else float(np.max(np.abs(fields(y0)[2]))) for k in done]
    chi_done = [k for k, i in enumerate(out.at_chi) if i < n_done]
    if chi_done:
        values = []
        for k in chi_done:
            with np.errstate(all="ignore"):  # a state overflowing the strain rates has chi = inf or nan
                z_f, chi = view.chi(fields(state_at(out.at_chi[k])))
                values.append(chi)
        result.chi_t, result.chi_z = np.array([float(sched.chi_times[k]) for k in chi_done]), z_f
        result.chi = np.array(values)
    # the last states passed before the run ended: the series' ring and the kept snapshots
    ring = out.at_last[out.at_last < n_done][-LAST_STATES:]
    kept = [i for i in np.flatnonzero(out.store >= 0) if i < n_done and i not in out.at_last]
    kept = [i for i in kept if i not in set(np.concatenate(out.at_recorders or [np.empty(0, int)]).tolist())]
    last = sorted(set(int(i) for i in ring) | set(int(i) for i in kept))[-LAST_STATES:]
    result.last_times = np.array([float(out.times[i]) for i in last])
    result.last_states = np.array([fields(state_at(i)) for i in last]).reshape(len(last), *shape)
    return result
