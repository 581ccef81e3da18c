"""Movies are playable: decoded back with ffmpeg, they have the frames that were rendered."""

import numpy as np
import pytest

from icidr_pde.movies.registry import MOVIES
from icidr_pde.movies.render import _FrameFigure, write_movie
from icidr_pde.movies.schedule import frame_times
from icidr_pde.movies.sink import ffmpeg_exe
from icidr_pde.movies.frames import MovieFrames


def _frames(n=12, nz=61):
    z = np.linspace(0, 30, nz)
    times = np.linspace(0, 1, n)
    frames = np.stack([np.stack([0.78 + 0.01 * np.sin(z / 3 + 6 * t), z / 30, 0.05 * np.sin(z / 5 - 6 * t)])
                       for t in times])
    return z, times, frames


def _decode(path):
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]


def _render(z, times, frames, k, dpi=100):
    """Frame k rendered directly by matplotlib, as RGB."""
    plot = _FrameFigure(z, times, frames, times, np.max(np.abs(frames[:, 2]), axis=1), "t", dpi)
    plot.update(times[k], frames[k])
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(plot.fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3]


def test_ffmpeg_comes_from_the_wheel():
    exe = ffmpeg_exe()
    assert exe and "imageio_ffmpeg" in exe


def test_mp4_decodes_to_the_rendered_frames(tmp_path):
    z, times, frames = _frames()
    path = write_movie(tmp_path / "m.mp4", z, times, frames, title="t")
    assert path == tmp_path / "m.mp4" and not list(tmp_path.glob(".*partial*"))
    decoded = _decode(path)
    assert len(decoded) == len(times)
    k = 7
    expected = _render(z, times, frames, k)
    h, w = min(expected.shape[0], decoded[k].shape[0]), min(expected.shape[1], decoded[k].shape[1])
    error = np.mean(np.abs(decoded[k][:h, :w].astype(float) - expected[:h, :w]))
    other = np.mean(np.abs(decoded[0][:h, :w].astype(float) - expected[:h, :w]))
    assert error < 0.5 * other and error < 5.0  # lossy codec: close to frame k, farther from frame 0


def test_gif_fallback_has_every_frame(tmp_path):
    from PIL import Image

    z, times, frames = _frames(n=5)
    path = write_movie(tmp_path / "m.gif", z, times, frames)
    with Image.open(path) as image:
        assert image.n_frames == 5


def test_bad_input_names_the_parameter(tmp_path):
    z, times, frames = _frames(n=3)
    with pytest.raises(ValueError, match="`path` must end in .mp4 or .gif"):
        write_movie(tmp_path / "m.avi", z, times, frames)
    with pytest.raises(ValueError, match="`frames` must have shape"):
        write_movie(tmp_path / "m.mp4", z, times[:2], frames)
    with pytest.raises(ValueError, match="`frame_dt` must be > 0"):
        frame_times(1.0, 0.0)


def test_a_failure_while_writing_leaves_no_file(tmp_path, monkeypatch):
    import icidr_pde.movies.render as movies

    def broken(plot, times, frames, reason, grab):
        grab(plot.fig)
        raise RuntimeError("disk full")

    monkeypatch.setattr(movies, "_add_frames", broken)
    z, times, frames = _frames(n=3)
    with pytest.raises(RuntimeError):
        write_movie(tmp_path / "m.mp4", z, times, frames)
    assert list(tmp_path.iterdir()) == []


def test_frame_times_are_a_fixed_interval():
    np.testing.assert_allclose(frame_times(1.0, 0.25), [0, 0.25, 0.5, 0.75, 1.0])
    np.testing.assert_allclose(frame_times(1.0, 0.3), [0, 0.3, 0.6, 0.9, 1.0])
    assert set(MOVIES) == {f"movie{k}" for k in range(1, 7)}


def test_movie_frames_and_failure_frame(tmp_path):
    """As the run path records them: one frame per frame time reached, then the state at t*
    of a failed run, titled with the reason."""
    z = np.linspace(0, 30, 65)[1::2]
    data = np.array([np.full(32, 0.78), z / 30, np.sin(z / 5)])
    frames = MovieFrames(tmp_path / "d.mp4", z, 1.0, 0.25, title="failing")
    for t in frames.output_times[frames.output_times <= 0.5]:
        data[2] *= 1.5
        frames.record(t, data)
    frames.failed(0.6, data * 10, "blow-up")
    frames.write()
    assert frames.times == [0.0, 0.25, 0.5, 0.6] and frames.failed_reason == "blow-up"
    assert len(_decode(frames.written)) == 4


def test_run_movie_shows_a_bar_over_its_frames(tmp_path, capsys):
    """`run --movie`: after the run's bar, a bar counts the frames written; the file has them all."""
    import imageio_ffmpeg

    from icidr_pde import cli

    path = tmp_path / "m.mp4"
    assert cli.main(["run", "--scene", "sine", "--N", "21", "--t-end", "1", "--frame-dt", "0.1",
                     "--movie", str(path)]) == 0
    n = len(frame_times(1.0, 0.1))
    err = capsys.readouterr().err
    assert f"m.mp4: frames: 100%" in err and f"{n}/{n}" in err.rsplit("m.mp4: frames", 1)[-1]
    assert err.index("done") < err.index("m.mp4: frames")  # the frames are written after the run
    assert imageio_ffmpeg.count_frames_and_secs(str(path))[0] == n


def test_a_movie_draws_its_figure_in_full_a_fixed_number_of_times(tmp_path, monkeypatch):
    """Each frame redraws only what moves (blitting): full draws of the figure, with its axes and
    tick labels, do not grow with the number of frames; a failure frame (axes rescaled) adds one."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    draws = []
    full_draw = FigureCanvasAgg.draw
    monkeypatch.setattr(FigureCanvasAgg, "draw", lambda self: draws.append(1) or full_draw(self))

    def count(n, reason=None):
        draws.clear()
        z, times, frames = _frames(n=n)
        path = write_movie(tmp_path / f"m{n}.mp4", z, times, frames, failed_reason=reason)
        assert len(_decode(path)) == n
        return len(draws)

    few = count(3)
    assert count(30) == few <= 2
    assert count(30, "blow-up") == few + 1


def test_movie_captions_name_the_scheme_as_the_discretization_does():
    from icidr_pde.discretizations import DISCRETIZATIONS

    for spec in MOVIES.values():
        label = DISCRETIZATIONS[spec.run["discretization"]].label
        assert label in spec.caption and "differences" not in spec.caption, spec.name


def test_the_failure_frame_shows_the_state_at_t_star(tmp_path, monkeypatch):
    """The last frame of a failed run is rescaled to the state at t* (1e6 times the regular frames here)
    and its title gives the head of the reason."""
    import icidr_pde.movies.render as movies

    plots = []
    figure = movies._FrameFigure
    monkeypatch.setattr(movies, "_FrameFigure", lambda *a: plots.append(figure(*a)) or plots[-1])
    z, times, frames = _frames(n=4)
    frames[-1, 2] *= 1e6
    write_movie(tmp_path / "m.mp4", z, times, frames, failed_reason="integrator failed (a long message)")
    plot = plots[0]
    assert plot.axes[2].get_ylim()[1] >= np.max(frames[-1, 2])
    assert plot.suptitle.get_text().endswith("FAILED at t* (integrator failed)")


# --- py-pde's own movies run the wheel's ffmpeg (icidr_pde/ffmpeg.py) -------------------------

PYPDE_MOVIES = r"""
import json, sys
import numpy as np
import pde
from icidr_pde import ShearCellPDE

out = sys.argv[1]
eq = ShearCellPDE("icidr")
grid = eq.make_grid(11, H=30)
state = eq.make_state(grid, 0.78, lambda z: z / 30 + 0.1 * np.sin(2 * np.pi * z / 30), 0.0)
storage = pde.MemoryStorage()
tracker = pde.PlotTracker(0.5, movie=out + "/tracker.mp4", show=False)
eq.solve(state, t_range=1, solver="stiff", tracker=[storage.tracker(0.25), tracker])
pde.visualization.movie(storage, out + "/movie.mp4", progress=False, movie_args={"dpi": 40})
fig = storage[0].plot(action="none")[0].ax.figure
print(json.dumps({"frames": len(storage), "size": [round(v) for v in fig.get_size_inches() * 40]}))
"""


def test_pypde_movies_find_the_wheels_ffmpeg(tmp_path):
    """With no ffmpeg on PATH (py-pde would say "FFMpegWriter is not available"), py-pde's
    ``movie`` and ``PlotTracker(movie=...)`` of this package's PDE write complete MP4s, with a
    frame per stored state (per tracker interval) at the figure's size in pixels."""
    import json
    import os
    import subprocess
    import sys

    import imageio_ffmpeg

    from icidr_pde.movies.sink import check_mp4

    empty = tmp_path / "bin"
    empty.mkdir()
    env = {**os.environ, "PATH": str(empty), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", PYPDE_MOVIES, str(tmp_path)], env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    expected = json.loads(done.stdout.strip().splitlines()[-1])
    assert expected["frames"] == 5  # t = 0, 0.25, ..., 1
    for name, frames, size in (("movie.mp4", expected["frames"], expected["size"]), ("tracker.mp4", 3, None)):
        path = tmp_path / name
        check_mp4(path)
        reader = imageio_ffmpeg.read_frames(str(path))
        meta = next(reader)
        assert sum(1 for _ in reader) == frames, name  # decoded, not the container's count
        if size is not None:
            assert list(meta["size"]) == size


def test_matplotlib_keeps_an_ffmpeg_it_can_find():
    """point_matplotlib fills in the wheel's ffmpeg only where matplotlib's setting names no
    program: a path that exists is kept."""
    import sys

    import matplotlib

    from icidr_pde.ffmpeg import point_matplotlib

    with matplotlib.rc_context({"animation.ffmpeg_path": sys.executable}):
        assert point_matplotlib() == sys.executable
        assert matplotlib.rcParams["animation.ffmpeg_path"] == sys.executable
    with matplotlib.rc_context({"animation.ffmpeg_path": "/nonexistent/ffmpeg"}):
        assert point_matplotlib() == ffmpeg_exe()
        assert matplotlib.rcParams["animation.ffmpeg_path"] == ffmpeg_exe()
