"""The native engine returns to Python every STEPS_BETWEEN_SIGNALS steps without an output, so that
Ctrl-C is seen during a long stretch between two outputs (a 2-D run with outputs only at 0 and
t_end), and the pauses change no number: CVODE goes on with the same steps after each.

Truth used: the same run without pauses (bit for bit, steps and state), the number of calls into C
(more than one for one output interval), and the failure at CVODE's step limit unchanged."""

import ctypes

import numpy as np
import pytest

native = pytest.importorskip("icidr_pde.native")
from icidr_pde import run  # noqa: E402
from icidr_pde.native import NativeProblem  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


class _Counting:
    """The compiled library, its advance calls counted (and Ctrl-C raised before call `stop_at`)."""

    def __init__(self, lib, stop_at=None):
        self._lib, self.calls, self.stop_at, self.steps = lib, 0, stop_at, [0]

    def __getattr__(self, name):
        return getattr(self._lib, name)

    def icidr_cvode_advance(self, handle, *args):
        self.calls += 1
        if self.calls == self.stop_at:
            raise KeyboardInterrupt  # as Python raises a signal that came during the previous call
        status = self._lib.icidr_cvode_advance(handle, *args)
        counts = (ctypes.c_long * 7)()
        self._lib.icidr_cvode_counts(handle, counts)
        self.steps.append(counts[0])  # CVODE's steps when C returned
        return status


@pytest.fixture
def counted(monkeypatch):
    """Every NativeProblem started from now on counts its calls into C; the list holds the counters."""
    class Counters(list):
        stop_at = None

        def set_stop(self, k):
            self.stop_at = k

    counters, start = Counters(), NativeProblem.start

    def counting_start(self, *args, **kwargs):
        scale = start(self, *args, **kwargs)
        counters.append(_Counting(self.lib, counters.stop_at))
        self.lib = counters[-1]
        return scale

    monkeypatch.setattr(NativeProblem, "start", counting_start)
    return counters


CASES = [("icidr", "sine", 101, 5.0), ("mui", "shear", 101, 5.0), ("icidr", "bump2d", (12, 12), 1.0)]


def _run(law, scene, n, t_end):
    return run(law, scene, n, t_end, ["0", f"{t_end:g}"], series_times=[], method="CVODE", engine="native")


@pytest.mark.parametrize("law, scene, n, t_end", CASES)
def test_pauses_change_no_number(monkeypatch, counted, law, scene, n, t_end):
    monkeypatch.setattr(native, "STEPS_BETWEEN_SIGNALS", native.MAX_STEPS)
    whole = _run(law, scene, n, t_end)
    assert max(np.diff(counted[-1].steps)) > 7  # C ran more than 7 steps without returning
    monkeypatch.setattr(native, "STEPS_BETWEEN_SIGNALS", 7)
    paused = _run(law, scene, n, t_end)
    assert max(np.diff(counted[-1].steps)) <= 7  # C returned to Python at least every 7 steps
    assert paused.n_steps == whole.n_steps and paused.reason == whole.reason
    assert paused.t_final == whole.t_final
    assert np.array_equal(np.asarray(paused.final), np.asarray(whole.final))


def test_ctrl_c_is_seen_within_the_steps_between_signals(monkeypatch, counted):
    """The interrupt Python raises when C returns (here at the third return) ends the run there,
    at most STEPS_BETWEEN_SIGNALS steps after the previous return, and the run reports CVODE's
    step."""
    monkeypatch.setattr(native, "STEPS_BETWEEN_SIGNALS", 20)
    counted.set_stop(3)
    r = _run("icidr", "sine", 101, 20.0)
    assert r.reason.startswith("interrupted at t = ")
    assert 0.0 < r.t_final < 20.0
    assert float(r.reason.split("= ")[1]) == pytest.approx(r.t_final, rel=1e-5)
    assert counted[-1].steps[-1] == r.n_steps <= 2 * 20


def test_the_step_limit_still_ends_the_run(monkeypatch):
    """CVODE's step limit towards one output is the run's, not a pause's: 60 steps with pauses
    every 7 fail where 60 steps without pauses fail (the same time, the same message)."""
    monkeypatch.setattr(native, "MAX_STEPS", 60)
    monkeypatch.setattr(native, "STEPS_BETWEEN_SIGNALS", 60)
    whole = _run("icidr", "sine", 101, 5.0)
    monkeypatch.setattr(native, "STEPS_BETWEEN_SIGNALS", 7)
    paused = _run("icidr", "sine", 101, 5.0)
    assert "mxstep" in whole.reason or "TOO_MUCH_WORK" in whole.reason, whole.reason
    assert paused.reason == whole.reason and paused.t_final == whole.t_final
