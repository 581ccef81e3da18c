"""Progress bar and live plot: phases, an honest end of a failed run, one figure updated in place.

Driven as the run path drives them: the bar (:class:`~icidr_pde.progress.TimeBar`) through
its phases, the live figure (:class:`~icidr_pde.live_plot.LivePlot`) as a recorder
(record at its output times, then finish with the state at t* of a failed run).
"""

import io

import numpy as np
import pytest

from icidr_pde.live_plot import LivePlot
from icidr_pde.progress import TimeBar


def _data(n=40):
    z = np.linspace(0, 30, 2 * n + 1)[1::2]
    return z, np.array([np.full(n, 0.78), z / 30, 0.01 * np.sin(z)])


def _bar(stream, t_end, times, **kwargs):
    bar = TimeBar(t_end, "compiling", file=stream, **kwargs)
    phase_after_start = bar.phase
    bar.integrating("compiled in 1.2 s")  # what the run path says once the kernels are built
    for t in times:
        bar.advance(t)
    return bar, phase_after_start


def test_progress_success_ends_at_t_end():
    stream = io.StringIO()
    bar, phase = _bar(stream, 1.0, [0.0, 0.5, 1.0])
    bar.close(1.0)
    assert phase == "compiling" and bar.phase == "done"
    assert bar.bar.n == pytest.approx(1.0)
    text = stream.getvalue()
    assert "compiling" not in text.rsplit("\r", 1)[-1] and "done" in text


def test_progress_failure_stops_at_t_star_and_says_why():
    stream = io.StringIO()
    bar, _ = _bar(stream, 10.0, [0.0, 0.005, 0.01])
    bar.close(0.01486, "failed", "step size underflow")
    assert bar.phase == "failed" and bar.bar.n == pytest.approx(0.01486)
    last = stream.getvalue().rsplit("\r", 1)[-1]
    assert "FAILED at t* = 0.01486 (step size underflow)" in last and "100%" not in last
    assert "t = 0.01486/10 [" in last and ": :" not in last  # the bar shows the failure time


def test_progress_shows_the_time_without_a_stray_separator():
    """tqdm puts ", " before {postfix}: the time must read "t = 0/1", "t = 0.5/1"."""
    stream = io.StringIO()
    bar, _ = _bar(stream, 1.0, [0.0, 0.5], log_interval=0)
    bar.close(1.0)
    lines = [line.strip() for line in stream.getvalue().replace("\n", "\r").split("\r") if line.strip()]
    assert lines[0].startswith("compiling:") and "t = 0/1 [" in lines[0]
    assert any(line.startswith("integrating (compiled in 1.2 s)") and "t = 0.5/1 [" in line for line in lines)
    assert lines[-1].startswith("done: 100%") and "t = 1/1 [" in lines[-1]
    assert not any("t = ," in line for line in lines)


@pytest.mark.parametrize("outcome, reason, said", [("interrupted", "", "interrupted at t = 0.25"),
                                                   ("stopped", "timeout after 1 s wall",
                                                    "stopped at t = 0.25 (timeout after 1 s wall)")])
def test_progress_of_a_run_ended_early_says_so(outcome, reason, said):
    stream = io.StringIO()
    bar, _ = _bar(stream, 1.0, [0.0, 0.25])
    bar.close(0.25, outcome, reason)
    last = stream.getvalue().rsplit("\r", 1)[-1]
    assert last.startswith(said) and "done" not in last and "t = 0.25/1 [" in last


def _record(live, data, times):
    for t in times:
        live.record(t, data)


def test_live_plot_draws_the_final_state_into_its_file(tmp_path):
    z, data = _data()
    out = tmp_path / "live.png"
    live = LivePlot(z, 1.0, show=False, output_file=out, chi=lambda data: (z, data[2] - 0.005))
    times = np.linspace(0, 1, 11)
    for_failure = data * 3
    _record(live, data, times)
    live.finish(1.0, for_failure, "x")
    assert out.read_bytes()[:4] == b"\x89PNG" and 1 <= live.n_draws <= len(times) + 1
    np.testing.assert_array_equal(live._lines["w"].get_ydata(), for_failure[2])  # last draw: the state at t*
    assert "FAILED" in live._suptitle.get_text()
    assert live.max_w[-1] == pytest.approx(np.max(np.abs(for_failure[2])))
    assert live.overhead_s > 0


def test_live_plot_budget_skips_redraws():
    """With a 1 % budget and handles in quick succession, most redraws are skipped (no timing
    is asserted: the budget only decides how many of the requested redraws happen)."""
    z, data = _data()
    live = LivePlot(z, 1.0, show=False, max_overhead=0.01)
    _record(live, data, np.linspace(0, 1, 101))
    live.finish()
    assert len(live.times) == 101 and live.n_draws < 101


def test_live_plot_rejects_bad_budget():
    with pytest.raises(ValueError, match="`max_overhead` must lie in \\(0, 1\\); got 1.5"):
        LivePlot([0, 1], 1.0, max_overhead=1.5)



def test_run_with_progress_and_movie_ends_at_t_star(tmp_path, capsys):
    """run(): the failed mu(I) run's bar stops at t* with the reason; its movie ends on the t* state."""
    from icidr_pde import run
    from icidr_pde.movies.schedule import frame_times

    path = tmp_path / "m.mp4"
    res = run("mui", "shear", 101, 1.0, [0], method="BDF", rtol=1e-6, atol=1e-9, progress=True,
              movie=str(path), frame_dt=0.01)
    assert res.blew_up
    err, frames_bar = capsys.readouterr().err.split("m.mp4: frames", 1)  # the movie's bar comes after the run's
    assert "100%" in frames_bar
    last = err.rstrip("\r").rsplit("\r", 1)[-1]
    assert f"FAILED at t* = {res.t_star:.5g}" in last and "100%" not in last and "compiling" in err
    assert f"t = {res.t_star:.4g}/1 [" in last
    import imageio_ffmpeg

    n_frames, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    assert n_frames == np.sum(frame_times(1.0, 0.01) <= res.t_star) + 1  # frames before t*, and t*


def test_native_progress_ends_at_the_failure_time(capsys):
    """The native engine's bar (the same TimeBar): a failed run ends at t* with the reason."""
    from icidr_pde.api import run

    res = run("mui", "shear", 201, 10.0, [0], progress=True, engine="native")
    assert res.blew_up
    last = capsys.readouterr().err.rsplit("\r", 1)[-1]
    assert last.startswith(f"FAILED at t* = {res.t_star:.5g} (") and ": :" not in last
    assert f"t = {res.t_star:.4g}/10 [" in last and "100%" not in last


def test_native_progress_of_a_run_that_ends_says_done(capsys):
    from icidr_pde.api import run

    res = run("icidr", "shear", 21, 0.5, progress=True, engine="native")
    assert not res.blew_up
    err = capsys.readouterr().err
    assert "integrating (native, ready in" in err
    assert err.rsplit("\r", 1)[-1].startswith("done: 100%") and "t = 0.5/0.5 [" in err and "t = ," not in err


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_live_plot_shows_an_early_blow_up_and_labels_clear_of_the_ticks():
    """The max|w| panel spans decades of t (a mu(I) failure at t ~ 1e-2 of t_end = 10 is not squashed
    into the first pixel column), and no y-label overlaps a tick label or the panel to its left."""
    z, data = _data()
    live = LivePlot(z, 10.0, show=False, chi=lambda data: (z, data[2]))
    for t in (0.0, 0.001, 0.005, 0.01):
        data[2] *= 10.0
        live.record(t, data)
    live.finish(0.0148, data * 1e6, "x")
    ax = live._axes[3]
    x_fraction = ax.transAxes.inverted().transform(ax.transData.transform((0.0148, 1.0)))[0]  # t* along the t axis
    assert 0.25 < x_fraction < 0.75, x_fraction
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(live.fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for k, ax in enumerate(live._axes):
        label = ax.yaxis.label.get_window_extent(renderer)
        ticks = [t.get_window_extent(renderer) for t in ax.get_yticklabels() if t.get_text()]
        assert ticks and not any(_overlap(label, t) for t in ticks), k
        if k:
            left = live._axes[k - 1].get_tightbbox(renderer)
            assert label.x0 >= left.x1, k
