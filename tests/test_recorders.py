"""The outputs of a run (snapshot file, movie frames, live plot) and the wall-clock limit are
recorders of the run path's one loop: no py-pde Controller, the same snapshots in the file as
in the Result, and an early end at an output, not a failure."""

from __future__ import annotations

import subprocess
import sys

import h5py
import numpy as np
import pytest

from icidr_pde import run


@pytest.fixture
def no_controller(monkeypatch):
    from pde.solvers import Controller

    def refused(self, *args, **kwargs):
        raise AssertionError("py-pde's Controller ran")

    monkeypatch.setattr(Controller, "run", refused)


def test_every_output_is_written_by_the_one_loop(tmp_path, no_controller):
    save, movie = tmp_path / "s.h5", tmp_path / "m.gif"
    res = run("icidr", "shear", 21, 1.0, ["0", "0.5", "1"], method="BDF", save=str(save), movie=str(movie),
              frame_dt=0.25, live_plot=True, max_wall=600, engine="pde")
    assert res.reason == "reached t_end" and not res.not_written
    with h5py.File(save) as fh:  # the file holds exactly the Result's snapshots
        np.testing.assert_array_equal(fh["times"][:], res.times)
        np.testing.assert_array_equal(fh["data"][:, 2], res.w)
    assert movie.stat().st_size > 0


def test_wall_clock_limit_ends_the_run_at_an_output_with_what_it_reached(tmp_path, no_controller):
    save = tmp_path / "s.h5"
    res = run("icidr", "shear", 21, 10.0, ["0", "5", "10"], method="BDF", save=str(save), max_wall=1e-9,
              engine="pde")
    assert res.reason.startswith("timeout after 1e-09 s wall at t = ")
    assert not res.blew_up and res.t_star is None
    assert 0 < res.t_final < 5 and res.time_labels == ["0"]
    assert res.max_w_t[-1] <= res.t_final and np.isfinite(np.array(res.final)).all()
    with h5py.File(save) as fh:  # written whole, with the snapshots reached
        np.testing.assert_array_equal(fh["times"][:], [0.0])


def test_interrupt_keeps_the_snapshot_file_of_the_times_reached(tmp_path, monkeypatch, no_controller):
    from icidr_pde.engines.scipy import ScipyEngine

    original = ScipyEngine.value_at

    def interrupting(self, t):
        if t > 0.5:
            raise KeyboardInterrupt
        return original(self, t)

    monkeypatch.setattr(ScipyEngine, "value_at", interrupting)
    save = tmp_path / "s.h5"
    res = run("icidr", "shear", 21, 10.0, ["0", "0.25", "5"], method="BDF", save=str(save))
    assert res.reason.startswith("interrupted")
    with h5py.File(save) as fh:
        np.testing.assert_array_equal(fh["times"][:], [0.0, 0.25])


def test_the_recorders_need_no_py_pde():
    code = ("import sys, icidr_pde.api, icidr_pde.live_plot, icidr_pde.movies.frames; "
            "icidr_pde.api.WallClock(1.0, 1.0); print('pde' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
