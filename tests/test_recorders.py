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


# --- every recorder on the native engine: the same content as on scikit-sundae's CVODE --------
# Independent truth: the same ODE (the scheme's rates) integrated by the py-pde path's engine
# (numba kernels, scikit-sundae's CVODE); the two agree to the tolerance, not bit for bit.

NATIVE_TOL = dict(method="CVODE", rtol=1e-9, atol=1e-11)


def _both(**kwargs):
    """The same run on the native engine and on the py-pde path's CVODE (scikit-sundae)."""
    native = run(**kwargs, engine="native", **NATIVE_TOL)
    pde = run(**kwargs, engine="pde", **NATIVE_TOL)
    assert native.settings["engine"] == "native" and pde.settings["engine"] == "sundae"  # no fall-back
    return native, pde


def _close(a, b, rel=1e-5):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape
    assert np.max(np.abs(a - b)) <= rel * np.max(np.abs(b)), np.max(np.abs(a - b))


def test_the_snapshot_file_on_the_native_engine(tmp_path):
    from icidr_pde.snapshots import read_snapshots

    files = {engine: tmp_path / f"{engine}.h5" for engine in ("native", "pde")}
    results = {}
    for engine, path in files.items():
        results[engine] = run("icidr", "sine", 21, 2.0, ["0", "0.5", "2"], save=str(path), engine=engine,
                              **NATIVE_TOL)
    assert results["native"].settings["engine"] == "native" and results["pde"].settings["engine"] == "sundae"
    native, pde = read_snapshots(files["native"]), read_snapshots(files["pde"])
    np.testing.assert_array_equal(native["times"], [0.0, 0.5, 2.0])
    np.testing.assert_array_equal(native["times"], pde["times"])
    np.testing.assert_array_equal(native["z"], pde["z"])
    np.testing.assert_array_equal(native["w"], results["native"].w)  # the file holds the Result's snapshots
    for field in ("phi", "u", "w"):
        _close(native[field], pde[field])
    assert np.max(np.abs(native["w"][-1])) > 1e-3  # the sine did evolve


def test_the_movie_frames_on_the_native_engine(tmp_path, monkeypatch):
    from icidr_pde.movies.frames import MovieFrames

    kept = []
    monkeypatch.setattr(MovieFrames, "write", lambda self: kept.append(self))  # the frames, not the rendering
    native, pde = _both(rheology="icidr", scene="sine", N=21, t_end=1.0, times=["0", "1"],
                        movie=str(tmp_path / "m.gif"), frame_dt=0.25)
    a, b = kept
    np.testing.assert_array_equal(a.times, [0.0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_array_equal(a.times, b.times)
    _close(a.frames, b.frames)
    np.testing.assert_array_equal(a.frames[-1], native.final)  # the last frame is the final state


def test_the_live_figure_on_the_native_engine(monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    from icidr_pde.live_plot import LivePlot

    kept = []
    original = LivePlot.close
    monkeypatch.setattr(LivePlot, "close", lambda self, outcome: kept.append(self) or original(self, outcome))
    native, pde = _both(rheology="icidr", scene="sine", N=21, t_end=1.0, times=["0", "1"], live_plot=True)
    a, b = kept
    assert len(a.times) > 100 and a.times == b.times
    _close(a.max_w, b.max_w)
    _close(a._last[0], native.final)


def test_the_wall_clock_limit_on_the_native_engine():
    native, pde = _both(rheology="icidr", scene="shear", N=21, t_end=10.0, times=["0", "5", "10"], max_wall=1e-9)
    assert native.reason == pde.reason and native.reason.startswith("timeout after 1e-09 s wall at t = ")
    assert native.t_final == pde.t_final and 0 < native.t_final < 5 and native.time_labels == ["0"]
    _close(native.final, pde.final)
