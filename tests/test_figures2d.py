"""The 2-D gallery entries (dims="2d") at draft resolution, against independent truth.

Truth used: the closed forms of docs/plane_waves.md written out here from Material's M and Psi
(the ill-posed interval |theta - beta| < arccos(M)/2, the worst-angle value 4 s (1 - M)/(phi Psi^2)),
the 1-D toolkit's Lambda_+ (stability.numeric, a separate code path) at theta = 90 deg, mass
conservation, and the findings of docs/sim2d.md (mu(I) fails on bump2d with t* falling under
refinement, the x-independent 1-D run decays, iCIDR decays).
"""

import numpy as np
import pytest

from icidr_pde.figures.gallery import write_gallery
from icidr_pde.figures.make import make_figures
from icidr_pde.figures.registry import FIGURES
from icidr_pde.figures.runs import RunCache
from icidr_pde.figures.two_d import bump2d_pair, spectrum_fraction
from icidr_pde.rheology import Material

NAMES_2D = ("polar2d", "bump2d", "tstar2d")


#: one worker under pytest-xdist: the module's fixtures are built once, not once per worker
pytestmark = pytest.mark.xdist_group("figures2d")


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    out = tmp_path_factory.mktemp("figures2d")
    runs = RunCache(draft=True)
    numbers = make_figures(list(NAMES_2D), out, draft=True, runs=runs, verbose=False)
    return out, runs, numbers


def test_2d_entries_are_registered_as_2d_and_drawn(drawn, tmp_path):
    out, _, numbers = drawn
    for name in NAMES_2D:
        assert FIGURES[name].dims == "2d"
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = write_gallery(numbers, tmp_path).read_text()
    for name in NAMES_2D:
        assert f"icidr-pde figures --only {name}" in page and f"({name}.png)" in page


def test_polar_ill_posed_interval_is_the_closed_form(drawn):
    """Steady shear u = z/30: beta = 45 deg, the interval 45 -+ arccos(M)/2 with M = mu(Psi(0.78))."""
    n = drawn[2]["polar2d"]
    m, phi0, s = Material(), 0.78, 0.5 / 30.0
    M, Psi = float(m.M(phi0)), float(m.Psi(phi0))
    half = np.degrees(np.arccos(M)) / 2
    [[a, b]] = n["mui_ill_posed_intervals_deg"]
    assert a == pytest.approx(45.0 - half, abs=1e-9) and b == pytest.approx(45.0 + half, abs=1e-9)
    assert n["mui_worst_angle_deg"] == pytest.approx(45.0, abs=1e-6)
    assert n["mui_max_lambda"] == pytest.approx(4 * s * (1 - M) / (phi0 * Psi**2), rel=1e-10)
    assert n["icidr_well_posed"] and n["icidr_max_lambda"] < 0


def test_polar_1d_direction_is_the_1d_toolkits_lambda_plus(drawn):
    from stability.numeric import stability_numbers

    one_d = stability_numbers("mui", 0.78, 1 / 30, 0.0).lambda_plus.real
    assert drawn[2]["polar2d"]["mui_lambda_at_90_deg"] == pytest.approx(one_d, rel=1e-10)
    assert one_d < 0  # the 1-D cell sees a stable direction of an ill-posed law


def test_bump2d_mui_fails_icidr_decays_at_the_same_time_mass_conserved(drawn):
    _, runs, numbers = drawn
    n = numbers["bump2d"]
    pair = bump2d_pair(runs)  # the runs the figure drew (cached in `runs`)
    mui, icidr = pair["mui"], pair["icidr"]
    assert mui.blew_up and not icidr.blew_up
    assert 0.9 < n["t_shown_over_t_star"] < 1.0
    assert np.any(np.isclose(icidr.times, n["t_shown"], rtol=0, atol=1e-12))
    assert abs(n["mass_drift_mui"]) < 1e-12 and abs(n["mass_drift_icidr"]) < 1e-12
    w0 = 0.05 / np.sqrt(2 * np.e)  # max|w(x, z, 0)| = eps max_s s exp(-s^2), at s = 1/sqrt(2)
    assert n["max_abs_w_icidr"] < w0 < n["max_abs_w_mui"]


def test_bump2d_growth_lies_in_the_closed_form_ill_posed_cone(drawn):
    """The mu(I) failure concentrates phi's energy in wave vectors inside |theta - 45| < arccos(M)/2."""
    n = drawn[2]["bump2d"]
    assert n["mui_phi_spectrum_fraction_in_ill_posed_cone"] > max(0.5, 1.5 * n["cone_share_of_angles"])


def test_spectrum_fraction_of_a_single_plane_wave():
    x = (np.arange(32) + 0.5) * 30 / 32
    X, Z = np.meshgrid(x, x, indexing="ij")
    wave = np.cos(2 * np.pi * (3 * X + 3 * Z) / 30)  # wave vector at 45 degrees
    assert spectrum_fraction(wave, 30, 30, 40, 50) == pytest.approx(1.0)
    assert spectrum_fraction(wave, 30, 30, 50, 130) == pytest.approx(0.0, abs=1e-20)


def test_tstar2d_findings_and_the_fresh_runs(drawn):
    n = drawn[2]["tstar2d"]
    assert n["t_star_2d_falls"]
    assert n["fresh_1d_decays"] and all(t is not None for t in n["fresh_t_star_2d"].values())
    fresh = list(n["fresh_t_star_2d"].values())
    assert all(a > b for a, b in zip(fresh, fresh[1:]))
    assert n["fresh_vs_committed_rel_max"] < 1e-4  # the committed study is what its code computes today


def _decode(path):
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]


def test_movie2d_has_every_frame_and_its_bar_counts_them(drawn, tmp_path, capsys):
    """The mp4 decodes to the snapshots kept plus mu(I)'s state at t*; the progress bar's total is that
    number and it ends there; the failure frame differs from the one before it."""
    from icidr_pde.figures.make import movie2d

    _, runs, _ = drawn
    mui = bump2d_pair(runs)["mui"]
    stride = 10
    info = movie2d(runs, tmp_path / "movie2d.mp4", stride=stride, dpi=50)
    expected = len(range(0, len(mui.times), stride)) + (0 if (len(mui.times) - 1) % stride == 0 else 1) + 1
    frames = _decode(tmp_path / "movie2d.mp4")
    assert info["frames"] == expected == len(frames)
    assert f"{expected}/{expected}" in capsys.readouterr().err
    assert np.mean(np.abs(frames[-1].astype(float) - frames[-2])) > 1.0
    assert not list(tmp_path.glob(".*partial*"))


def test_movie2d_bad_input_names_the_parameter(drawn, tmp_path):
    from icidr_pde.movies.render import movie_from_results_2d, write_field_movie

    pair = bump2d_pair(drawn[1])
    with pytest.raises(ValueError, match="`stride` must be an integer >= 1"):
        movie_from_results_2d({"a": pair["mui"]}, tmp_path / "m.mp4", stride=0)
    with pytest.raises(ValueError, match="`path` must end in .mp4 or .gif"):
        write_field_movie(tmp_path / "m.avi", (0, 1, 0, 1), [0.0], {"a": np.zeros((1, 2, 3, 3))})
    with pytest.raises(ValueError, match="`frames` must map labels"):
        write_field_movie(tmp_path / "m.mp4", (0, 1, 0, 1), [0.0, 1.0], {"a": np.zeros((1, 2, 3, 3))})


def test_the_plot_of_a_2d_run_shows_its_last_fields(tmp_path):
    """``--plot`` of a 2-D run (plotting.plot_result): the images are w and phi - phi0 of the last
    snapshot, the third panel max|w|(t) of the run."""
    from matplotlib.image import AxesImage

    from icidr_pde import run
    from icidr_pde.plotting import plot_result

    result = run("icidr", "bump2d", (8, 8), 0.2, ["0", "0.2"], method="CVODE", rtol=1e-6, atol=1e-9)
    path = tmp_path / "fields.png"
    fig = plot_result(result, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    images = [a for ax in fig.axes for a in ax.get_children() if isinstance(a, AxesImage)]
    np.testing.assert_array_equal(images[0].get_array(), result.w[-1].T)
    np.testing.assert_allclose(images[1].get_array(), (result.phi[-1] - result.scene_params["phi0"]).T)
    np.testing.assert_array_equal(fig.axes[2].lines[0].get_ydata(), result.max_w_series)


# --- tstar2d beyond 128^2: the committed large-grid studies, drawn where they exist ---------------


def _large_folder(tmp_path, with_large=True):
    """A data folder with the committed sim2d studies and, `with_large`, large-grid studies made from
    them: the committed convergence grids 16-128 relabelled 256-2048, two t* rows at 256 and 512."""
    import json
    import shutil

    from icidr_pde.figures.runs import DATA

    (tmp_path / "sim2d").mkdir()
    for name in ("tstar.json", "convergence.json"):
        shutil.copy(DATA / "sim2d" / name, tmp_path / "sim2d" / name)
    if not with_large:
        return tmp_path, None, None
    settings = {"method": "CVODE", "rtol": 1e-5, "atol": 1e-8, "jacobian": "fourier"}
    conv = json.loads((DATA / "sim2d" / "convergence.json").read_text())
    relabel = {str(n): str(16 * n) for n in conv["sizes"]}
    conv_large = {**conv, "settings": settings, "sizes": [16 * n for n in conv["sizes"]],
                  "runs": {relabel[n]: run for n, run in conv["runs"].items()}}
    tstar_large = {"scene": "bump2d", "rheology": "mui", "t_end": 10.0, "settings": settings,
                   "rows": [{"N": 256, "t_star_2d": 0.0287, "reason_2d": "x", "t_star_1d": 0.12, "reason_1d": "x",
                             "max_w_1d_end": None},
                            {"N": 512, "t_star_2d": 0.0177, "reason_2d": "x", "t_star_1d": 0.033, "reason_1d": "x",
                             "max_w_1d_end": None}]}
    (tmp_path / "sim2d" / "convergence_large.json").write_text(json.dumps(conv_large))
    (tmp_path / "sim2d" / "tstar_large.json").write_text(json.dumps(tstar_large))
    return tmp_path, conv_large, tstar_large


def _draw_tstar2d(drawn, folder, monkeypatch):
    """tstar2d on the data of `folder`, its small fresh studies taken from the gallery's (recorded:
    the sizes every study was asked for)."""
    from icidr_pde.figures import two_d
    from icidr_pde.studies import sim2d

    fresh, asked = drawn[1]._results["sim2d-fresh"], []

    def study(part):
        def run_it(sizes, *args, **kwargs):
            asked.extend(sizes)
            return fresh[part]
        return run_it

    monkeypatch.setattr(two_d, "DATA", folder)
    monkeypatch.setattr(sim2d, "tstar_study", study("tstar"))
    monkeypatch.setattr(sim2d, "convergence_study", study("convergence"))
    fig, numbers = two_d.tstar2d(RunCache(draft=True))
    return fig, numbers, asked


def test_tstar2d_draws_the_large_grids_beside_the_committed_ones(drawn, tmp_path, monkeypatch):
    folder, conv_large, tstar_large = _large_folder(tmp_path)
    fig, n, asked = _draw_tstar2d(drawn, folder, monkeypatch)
    assert asked and max(asked) <= 128  # the gallery runs none of the large grids
    assert n["large_t_star_2d"] == {256: 0.0287, 512: 0.0177} and n["large_t_star_1d"] == {256: 0.12, 512: 0.033}
    assert n["large_t_star_2d_falls"]
    assert n["large_max_w"] == {int(k): run["max_w"] for k, run in conv_large["runs"].items()}
    heading = FIGURES["tstar2d"].heading(n)
    assert "256²-512²" in heading and "256²-2048²" in heading and "rtol 1e-05" in heading, heading
    # (a): the large t* as their own line, after the committed ones
    (a, b, c) = fig.axes[:3]
    [line] = [l for l in a.get_lines() if l.get_label().startswith("2-D, 256²-512²")]
    assert list(line.get_xdata()) == [256, 512] and list(line.get_ydata()) == [0.0287, 0.0177]
    # (b): max|w| at 256-2048 for every time
    big = [l for l in b.get_lines() if list(l.get_xdata()) == [256, 512, 1024, 2048]]
    assert len(big) == len(conv_large["times"])
    # (c): the differences of each family alone: |q(N) - q(2N)| within 16-128 and within 256-2048
    sizes = conv_large["sizes"]
    want = [abs(conv_large["runs"][str(p)]["max_w"]["1"] - conv_large["runs"][str(q)]["max_w"]["1"])
            for p, q in zip(sizes, sizes[1:])]
    assert list(n["large_successive_differences"]["max_w"]["1"].values()) == want
    xs = {round(float(x), 12) for l in c.get_lines() if len(l.get_xdata()) and l.get_linestyle() in ("-", "--")
          and l.get_label() not in ("order 1", "order 2") for x in l.get_xdata()}
    assert xs == {round(30.0 / m, 12) for m in (16, 32, 64, 256, 512, 1024)}  # no pair 128-256 across families
    assert any(list(l.get_ydata()) == want for l in c.get_lines())


def test_tstar2d_without_the_large_files_draws_what_it_has_and_says_so(drawn, tmp_path, monkeypatch):
    folder, _, _ = _large_folder(tmp_path, with_large=False)
    fig, n, asked = _draw_tstar2d(drawn, folder, monkeypatch)
    assert max(asked) <= 128
    assert n["large_t_star_2d"] == {} and n["large_max_w"] == {} and n["large_successive_differences"] == {}
    assert "no data/sim2d/*_large.json" in FIGURES["tstar2d"].heading(n)
    assert all(max(l.get_xdata(), default=0) <= 128 for l in fig.axes[0].get_lines())


def test_tstar2d_numbers_are_the_committed_large_studies_or_none(drawn):
    """The gallery's drawing reads data/sim2d/*_large.json as they are in the repository."""
    import json

    from icidr_pde.figures.runs import DATA

    n = drawn[2]["tstar2d"]
    path = DATA / "sim2d" / "tstar_large.json"
    rows = json.loads(path.read_text())["rows"] if path.is_file() else []
    assert n["large_t_star_2d"] == {r["N"]: r["t_star_2d"] for r in rows if r["t_star_2d"] is not None}
