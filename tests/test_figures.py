"""The figures show what the paper and independent computations say (draft resolution, N = 101).

Truth used: the initial condition (3.16) and chi (A18) evaluated by hand from their formulas,
the simulator's iCIDR stress kernel (for the yield ratio of fig 5), the paper's findings
(figs 3, 4, 6, 7), and run() called independently with other snapshot times.
"""

import json

import numpy as np
import pytest
from scipy.optimize import brentq

from icidr_pde import run
from icidr_pde.figures.gallery import write_gallery
from icidr_pde.figures.make import make_figures
from icidr_pde.figures.panels import positive_intervals
from icidr_pde.figures.paper import yield_ratio
from icidr_pde.figures.registry import FIGURES
from icidr_pde.figures.runs import DATA, RUNS, RunCache
from icidr_pde.movies.registry import PAPER_SETTINGS
from icidr_pde.rheology import ICIDR, Material


#: one worker under pytest-xdist: the module's fixtures are built once, not once per worker
pytestmark = pytest.mark.xdist_group("figures")


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    out = tmp_path_factory.mktemp("figures")
    runs = RunCache(draft=True)
    numbers = make_figures(["fig2", "fig3", "fig4", "fig5", "fig6", "fig7", "fig1", "fig8"], out,
                           draft=True, runs=runs, verbose=False)
    return out, runs, numbers


def test_positive_intervals():
    z = np.arange(10.0)
    assert positive_intervals(z, [-1, 1, 2, -1, -1, 3, -2, 4, 4, 4]) == [[1, 2], [5, 5], [7, 9]]
    assert positive_intervals(z, -np.ones(10)) == []


def test_every_figure_is_a_png(drawn):
    out, _, numbers = drawn
    for name in numbers:
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_fig2_is_the_initial_condition_and_chi_is_positive_in_the_centre(drawn):
    """Fig 2: w(z, 0) of (3.16) and chi > 0 exactly where w_z/|u_z| > M/sqrt(1 - M^2) (A18)."""
    _, runs, numbers = drawn
    res = runs["mui-fd-fine"]
    H, eps, phi0 = 30.0, 0.05, 0.78
    zc = res.z - H / 2
    np.testing.assert_allclose(res.w[0], eps * zc * np.exp(-zc**2), atol=1e-15)
    np.testing.assert_allclose(res.u[0], res.z / H, atol=1e-15)
    M = float(Material().M(phi0))
    # w_z = eps (1 - 2 x^2) exp(-x^2), u_z = 1/H: chi = 0 where H w_z = M / sqrt(1 - M^2)
    x0 = brentq(lambda x: H * eps * (1 - 2 * x**2) * np.exp(-x**2) - M / np.sqrt(1 - M**2), 0, 0.7)
    [[a, b]] = numbers["fig2"]["chi_positive_z"]
    h = H / res.N
    assert abs(a - (H / 2 - x0)) < h and abs(b - (H / 2 + x0)) < h


def test_fig3_fig4_paper_findings_and_agreement_with_an_independent_run(drawn):
    """Figs 3, 4: both fine runs fail before t = 0.1, N = 47 decays; t* is the one run() gives
    with other snapshot times (the integrator's steps do not depend on the trackers)."""
    _, runs, numbers = drawn
    n3, n4 = numbers["fig3"], numbers["fig4"]
    assert 0 < n3["t_star_fd_fine"] < 0.1 and 0 < n3["t_star_cheb_fine"] < 0.1
    assert not n3["coarse_blew_up"] and n3["coarse_max_w_t10"] < 0.05 * n3["max_w0"]
    assert n4["t_star_mui-cheb-coarse"] is None
    assert abs(n3["argmax_z_before_tstar_fd"] - 15.0) < 3.0  # the growth starts in the centre, where chi > 0
    again = run("mui", "shear", runs["mui-cheb-fine"].N, 1.0, [0, 0.01], discretization="cheb", **PAPER_SETTINGS)
    assert again.t_star == pytest.approx(n3["t_star_cheb_fine"], rel=1e-9)


def test_fig5_yield_ratio_is_the_simulators_stress(drawn):
    """Fig 5's Y/p of (4.7), at the I of (4.10)-(4.11), is ||tau||/p of the iCIDR kernel."""
    rng = np.random.default_rng(5)
    phi, uz, wz = rng.uniform(0.7, 0.81, 50), rng.uniform(-0.3, 0.3, 50), rng.uniform(-0.2, 0.2, 50)
    p, txz, tzz = ICIDR().stress(phi, uz, wz)
    I = np.sqrt(uz**2 + wz**2) / np.sqrt(p)  # (2.9): I = 2||S||/sqrt(p), ||S||^2 = (u_z^2 + w_z^2)/4
    np.testing.assert_allclose(np.hypot(txz, tzz) / p, yield_ratio(I, phi), rtol=1e-12)
    m = Material()
    for phi_, I_iso, mu_iso in drawn[2]["fig5"]["isochoric_points_phi_I_mu"]:  # dots: I = Psi(phi) (4.6)
        assert I_iso == pytest.approx((m.phi_c - phi_) / m.a) and mu_iso == pytest.approx(float(m.mu(I_iso)))


def test_fig6_fig7_grid_converged_with_local_maximum_near_3(drawn):
    """Figs 6, 7: no blow-up, grids agree (2 % / 5 % of max|w|(0)), a local maximum of max|w| near
    t = 3 (fig 7e); chi of IC (5.7) is infinite at two points, where u_z = 0 (fig 7d)."""
    n6, n7 = drawn[2]["fig6"], drawn[2]["fig7"]
    assert not n6["blew_up"] and n6["grid_difference_rel_max_w0"] < 0.02
    assert not n7["blew_up"] and n7["grid_difference_rel_max_w0"] < 0.05
    assert any(2.0 < t < 4.5 for t, _ in n7["max_w_local_maxima_after_t1"])
    # u = z/H + a sin(2 pi z/H): u_z = 0 where cos(2 pi z/H) = -1/(2 pi a/H)
    H, a = 30.0, 0.16
    x = np.arccos(-1 / (2 * np.pi * a))
    roots = H / (2 * np.pi) * np.array([x, 2 * np.pi - x])
    h = H / drawn[1]["icidr-sine-fd-fine"].N
    intervals = n7["chi_positive_z"]
    for root in roots:  # each u_z = 0 point lies in (or within a cell of) a chi > 0 interval
        assert any(lo - h <= root <= hi + h for lo, hi in intervals)


def test_fig1_fig8_from_committed_dem_data(drawn):
    n1, n8 = drawn[2]["fig1"], drawn[2]["fig8"]
    assert n1["max_abs_mu_minus_table1"] < 0.05 and n1["max_abs_phi_minus_table1"] < 0.01
    assert n8["rel_error_table1_max"] < 0.025  # the paper: iCIDR within 2.5 % of DEM


def test_gallery_lists_every_figure_with_its_command(drawn, tmp_path):
    out, _, numbers = drawn
    page = write_gallery(numbers, tmp_path).read_text()
    for name in numbers:
        assert f"icidr-pde figures --only {name}" in page and f"({name}.png)" in page
    assert "2-D" in page  # the documented slot


def test_cli_figures_rejects_unknown_names(capsys):
    from icidr_pde.cli import main

    assert main(["figures", "--only", "fig99", "--out", "/tmp"]) == 2
    assert "fig99" in capsys.readouterr().err and "fig3" in FIGURES


@pytest.mark.slow
def test_fig4_paper_resolution_chebyshev_tstar(tmp_path):
    """Fig 4(a) at N = 201: the Chebyshev t* is the paper's 0.01052 to within 1 %."""
    numbers = make_figures(["fig4"], tmp_path, verbose=False)
    assert numbers["fig4"]["t_star_mui-cheb-fine"] == pytest.approx(0.01052, rel=0.01)
    assert json.dumps(numbers)


# --- labels that say what is drawn (issue 21) ----------------------------------------------------------------------


def test_fig7_draws_chi_infinite_where_u_z_changes_sign():
    """chi (A18) is infinite where its denominator |u_z| vanishes. For IC (5.7), u = z/H + a sin(2 pi z/H),
    u_z = 0 at two points either side of the centre (brentq on the closed form); the figure finds them
    between the faces to O(h^2) and draws one dotted line at each."""
    runs = RunCache(draft=True)
    fig, numbers = FIGURES["fig7"].draw(runs)
    fine = runs["icidr-sine-fd-fine"]
    H, a = fine.scene_params["H"], fine.scene_params["a"]

    def u_z(z):
        return 1 / H + a * 2 * np.pi / H * np.cos(2 * np.pi * z / H)

    exact = [brentq(u_z, 0.4 * H, H / 2), brentq(u_z, H / 2, 0.6 * H)]
    h = H / fine.N
    assert numbers["chi_infinite_z"] == pytest.approx(exact, abs=h * h / 4)
    dotted = [line.get_xdata()[0] for line in fig.axes[3].get_lines() if line.get_linestyle() == ":"]
    assert dotted == pytest.approx(numbers["chi_infinite_z"])


def test_sign_changes_interpolates_between_nodes():
    from icidr_pde.figures.panels import sign_changes

    x = np.linspace(0, 1, 11)
    assert sign_changes(x, x - 0.33) == pytest.approx([0.33])  # linear: exact
    assert sign_changes(x, x - 0.3) == pytest.approx([0.3])  # a zero on a node, counted once
    assert sign_changes(x, x + 1) == []


def test_fig8_heading_counts_the_dem_runs_of_the_data(tmp_path):
    ensemble = np.load(DATA / "dem" / "transient_ensemble.npz")
    runs = int(ensemble["repeats"])
    assert runs == json.loads((DATA / "dem" / "transient.json").read_text())["repeats"]
    fig, numbers = FIGURES["fig8"].draw(RunCache(draft=True))
    page = write_gallery({"fig8": {"png": "fig8.png", "seconds": 1.0, "draft": False, **numbers}}, tmp_path).read_text()
    assert f"## fig8: iCIDR (Table 1) against the mean of {runs} DEM runs" in page


def test_draft_headings_name_the_draft_grid(tmp_path):
    """A draft is drawn at N = 101 (RUNS): its gallery headings must not say N = 201."""
    drafted = {spec.N[1] for spec in RUNS.values()}
    assert 201 not in drafted
    numbers = {name: {"png": f"{name}.png", "seconds": 1.0, "draft": True, "dem_runs": 30} for name in FIGURES}
    page = write_gallery(numbers, tmp_path).read_text()
    headings = [line for line in page.splitlines() if line.startswith("## ")]
    assert any("N = 101" in h for h in headings) and not any("201" in h for h in headings)
    full = write_gallery({k: {**v, "draft": False} for k, v in numbers.items()}, tmp_path).read_text()
    assert "N = 201 fails" in full


class _FakeRun:
    """Just what fig 4(a) reads of a Result."""

    def __init__(self, discretization, N, t_star):
        self.discretization, self.N, self.t_star, self.blew_up = discretization, N, t_star, t_star is not None
        self.max_w_t = np.geomspace(1e-4, t_star or 10.0, 50)
        self.max_w_series = 0.05 * np.exp(self.max_w_t / (t_star or 1e3) * 10)
        self.method, self.rtol = "BDF", 1e-6  # panel (b)'s label names how panel (a)'s run was computed


def test_fig4_legend_explains_the_failure_marks_and_names_finite_volumes():
    runs = {"mui-fd-fine": _FakeRun("fd", 201, 0.0148), "mui-cheb-fine": _FakeRun("cheb", 201, 0.0105),
            "mui-fd-coarse": _FakeRun("fd", 47, None), "mui-cheb-coarse": _FakeRun("cheb", 47, None)}
    fig, _ = FIGURES["fig4"].draw(runs)
    ax = fig.axes[0]
    assert "x:" not in ax.get_title()
    legend = {text.get_text(): handle for text, handle in zip(ax.get_legend().get_texts(), ax.get_legend().legend_handles)}
    assert any("t*" in label and handle.get_marker() == "x" for label, handle in legend.items())
    assert "finite volumes, N = 201" in legend and not any("differences" in label for label in legend)


def test_draft_never_overwrites_the_committed_gallery(tmp_path, monkeypatch, capsys):
    """`figures --draft` writes into figures-draft/ by default; into a folder holding a full-resolution
    gallery only with --force."""
    from icidr_pde.cli import main

    monkeypatch.chdir(tmp_path)
    gallery = tmp_path / "docs" / "figures"
    gallery.mkdir(parents=True)
    committed = json.dumps({"meta": {}, "figures": {"fig8": {"png": "fig8.png", "draft": False}}})
    (gallery / "numbers.json").write_text(committed)
    assert main(["figures", "--draft", "--only", "fig8"]) == 0
    assert (tmp_path / "figures-draft" / "fig8.png").is_file() and not (gallery / "fig8.png").exists()
    assert main(["figures", "--draft", "--only", "fig8", "--out", "docs/figures"]) == 2
    err = capsys.readouterr().err
    assert "`--out` docs/figures holds a full-resolution gallery" in err and "--force" in err
    assert (gallery / "numbers.json").read_text() == committed and not (gallery / "fig8.png").exists()
    assert main(["figures", "--draft", "--only", "fig8", "--out", "docs/figures", "--force"]) == 0
    assert json.loads((gallery / "numbers.json").read_text())["figures"]["fig8"]["draft"] is True


def test_tstar_plot_names_the_scheme_as_the_discretization_does(tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from icidr_pde.figures.tstar_plot import plot_tstar

    legends = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: legends.extend(
        t.get_text() for ax in self.axes if ax.get_legend() for t in ax.get_legend().get_texts()))
    plot_tstar({"fd": {"61": 0.66, "59": None}}, str(tmp_path / "t.png"), t_end=20.0)
    assert any(text.startswith("finite volumes, all fail for N >= 61") for text in legends), legends
