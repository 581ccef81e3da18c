"""The numbers the documentation quotes are those of the files the commands wrote.

Truth used: the committed results in data/ and docs/figures/numbers.json (written by the studies,
sweeps and `icidr-pde figures`), and the tables those commands print from them
(`icidr-pde study sim2d tables`, the gallery page). A quoted number agrees when it is
the file's value rounded to the digits the page shows; a page that says more digits than the
file holds, or another value, fails.

The measurement pages (chebyshev.md, performance.md, scaling.md) hold timings of one machine at
one moment: a table there that names its command is either checked here against the data file it
quotes or marked as a dated record (its command, date and machine) whose command still exists.
"""

import json
import math
import re
import shlex
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
DATA = ROOT / "data"


def page(name: str) -> str:
    return (DOCS / name).read_text()


def data(path: str):
    return json.loads((DATA / path).read_text())


def agrees(quoted: str, value: float) -> bool:
    """True if `quoted` ("0.0148", "4.9e-3", "−1.23", "2.6%") is `value` rounded to the digits shown."""
    text = quoted.strip().replace("−", "-").replace("\u2212", "-")
    scale = 1.0
    if text.endswith("%"):
        text, scale = text[:-1], 100.0
    mantissa = re.split(r"[eE]", text)[0].lstrip("+-")
    digits = len(mantissa.replace(".", "").lstrip("0")) or 1
    shown = float(text)
    if value == 0 or shown == 0:
        return shown == value * scale
    value = value * scale
    rounded = float(f"{value:.{digits - 1}e}")
    return math.isclose(shown, rounded, rel_tol=1e-9)


def test_agrees_is_strict():
    assert agrees("0.0148", 0.014782860) and agrees("4.9e-3", 0.0048869) and agrees("2.6%", 0.02628)
    assert agrees("−1.23", -1.2324) and agrees("0.260", 0.25967)
    assert not agrees("0.0149", 0.014782860) and not agrees("0.2634", 0.25967) and not agrees("2.7%", 0.02628)
    assert not agrees("0.26341", 0.2634)  # more digits than the value supports are a different number


def table_after(text: str, marker: str) -> list[list[str]]:
    """The cells of the first Markdown table after the line containing `marker` (header row first)."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if marker in line)
    rows = []
    for line in lines[start + 1:]:
        if line.startswith("|"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip())[1:-1]]
            if not all(re.fullmatch(r":?-+:?", c) for c in cells):
                rows.append(cells)
        elif rows:
            break
    assert rows, f"no table after {marker!r}"
    return rows


# --- 1-D results (docs/results.md, docs/chebyshev.md) ----------------------------------------

TSTAR_CHEB = "tstar/mui_shear_cheb_BDF_rtol1e-6_atol1e-9.json"
TSTAR_FD = "tstar/mui_shear_fd_BDF_rtol1e-6_atol1e-9.json"


TSTAR_STATED = "tstar/mui_shear_stated.json"
TSTAR_ACCURACY = "tstar/tstar_accuracy.json"


def tstar_sweep(path, discretization=None):
    """N -> t* (None: no failure by t_end) of a committed sweep, in either of its forms (the `tstar
    --json` document: the curve of `discretization`)."""
    from icidr_pde.studies.failure_time import read_tstar_curves

    curves = read_tstar_curves(data(path))
    curve = curves[discretization] if discretization is not None else next(iter(curves.values()))
    return {int(n): t for n, t in curve.items()}


def tolerance_run(discretization, method, rtol, atol):
    rows = [r for r in data("tstar/tolerance_study_N201.json")
            if (r["discretization"], r["method"], r["rtol"], r["atol"]) == (discretization, method, rtol, atol)]
    assert len(rows) == 1, (discretization, method, rtol, atol)
    return rows[0]["t_star"]


def test_results_headline_tstar():
    text = page("results.md")
    cheb = tstar_sweep(TSTAR_CHEB)
    quoted = re.search(r"fails at \*\*t\\\* = ([\d.]+)\*\* \(paper: 0\.01052, \+0\.6 %; with atol 1e-6: ([\d.]+)", text)
    assert quoted, "results.md: the headline sentence changed; update this test with it"
    assert agrees(quoted.group(1), cheb[201])
    assert agrees(quoted.group(2), tolerance_run("cheb", "BDF", 1e-6, 1e-6))
    converged = data("reference/mui-shear-tstar-cheb.json")["t_star"]
    for number in re.findall(r"(?:converged \(tight tolerances, every integrator\)|all integrators agree on) ([\d.]*\d)", text):
        assert agrees(number, converged)
    loose = re.search(r"gives t\* = ([\d.]+) \(BDF\), ([\d.]+) \(CVODE\), ([\d.]+) \(LSODA\), ([\d.]+) \(Radau\)", text)
    assert loose
    for number, method in zip(loose.groups(), ("BDF", "CVODE", "LSODA", "Radau")):
        assert agrees(number, tolerance_run("cheb", method, 1e-3, 1e-6)), method


def first_failing_N(sweep):
    """The smallest N from which every larger N of the sweep fails."""
    Ns = sorted(sweep)
    decays = [n for n in Ns if sweep[n] is None]
    return min(n for n in Ns if n > max(decays, default=0))


def test_results_thresholds_and_fd_table():
    text = page("results.md")
    cheb, fd = tstar_sweep(TSTAR_CHEB), tstar_sweep(TSTAR_FD)
    m = re.search(r"every run fails for N ≥ (\d+) with Chebyshev\s+and for N ≥ (\d+) with finite volumes", text)
    assert m and (int(m.group(1)), int(m.group(2))) == (first_failing_N(cheb), first_failing_N(fd))
    head, values = table_after(text, "data/tstar/mui_shear_fd_BDF_rtol1e-6_atol1e-9.json;")
    for n, quoted in zip(head[1:], values[1:]):
        if fd[int(n)] is None:
            assert quoted.startswith("no failure"), n
        else:
            assert agrees(quoted, fd[int(n)]), (n, quoted, fd[int(n)])


def test_chebyshev_headline_and_fig4b():
    text = page("chebyshev.md")
    cheb, fd = tstar_sweep(TSTAR_CHEB), tstar_sweep(TSTAR_FD)
    rows = table_after(text, "BDF (scipy), rtol = 1e-6, analytic Jacobian")
    assert agrees(rows[1][1], tolerance_run("cheb", "BDF", 1e-6, 1e-9)) and agrees(rows[1][1], cheb[201])
    assert agrees(rows[2][1], tolerance_run("cheb", "BDF", 1e-6, 1e-6))
    assert agrees(re.search(r"fails\s+at t\* = ([\d.]+) \(BDF, rtol 1e-6, atol 1e-9\)", text).group(1), fd[201])
    m = re.search(r"\*\*Chebyshev: N >= (\d+)\*\* \(t\* = ([\d.]+) at N = \d+\); \*\*finite volumes:\s+"
                  r"N >= (\d+)\*\* \(t\* = ([\d.]+) at N = \d+\)", text)
    assert m, "chebyshev.md: the thresholds sentence changed; update this test with it"
    assert int(m.group(1)) == first_failing_N(cheb) and agrees(m.group(2), cheb[first_failing_N(cheb)])
    assert int(m.group(3)) == first_failing_N(fd) and agrees(m.group(4), fd[first_failing_N(fd)])


def test_chebyshev_fig4b_default_and_the_accuracy_of_a_tstar():
    """docs/chebyshev.md's fig 4(b) of the default settings and its accuracy statement, against
    data/tstar/mui_shear_stated.json and data/tstar/tstar_accuracy.json."""
    text = page("chebyshev.md")
    cheb, fd = tstar_sweep(TSTAR_STATED, "cheb"), tstar_sweep(TSTAR_STATED, "fd")
    m = re.search(r"The default finds the same: Chebyshev from N = (\d+) on\s+\(t\* = ([\d.]+) at N = \d+\), "
                  r"finite volumes from N = (\d+) on \(t\* = ([\d.]+) at N = \d+\)", text)
    assert m, "chebyshev.md: the default's thresholds sentence changed; update this test with it"
    assert int(m.group(1)) == first_failing_N(cheb) and agrees(m.group(2), cheb[first_failing_N(cheb)])
    assert int(m.group(3)) == first_failing_N(fd) and agrees(m.group(4), fd[first_failing_N(fd)])
    study = data(TSTAR_ACCURACY)
    assert agrees(re.search(r"rtol 1e-9 and 1e-10\s+agree to ([\d.e-]+) at every N", text).group(1),
                  max(study["cheb"]["converged_error"].values()))
    scatter = {int(n): e for n, e in study["fd"]["scatter"].items() if study["fd"]["reference"][n] is not None}
    every = {int(n): e for n, e in study["fd"]["scatter_all"].items() if e is not None}
    m = re.search(r"scatter by up to ([\d.]+) % of\s+their median at N ≥ 121 and up to ([\d.]+) %", text)
    assert agrees(m.group(1) + "%", max(e for n, e in scatter.items() if n >= 121))
    assert agrees(m.group(2) + "%", max(e for n, e in scatter.items() if n < 121))
    m = re.search(r"lies within ([\d.]+) % of the\s+median at N ≥ 121, within ([\d.]+) % below", text)
    assert agrees(m.group(1) + "%", max(e for n, e in every.items() if n >= 121))
    assert agrees(m.group(2) + "%", max(e for n, e in every.items() if n < 121))
    rows = table_after(text, "load of the run):")
    assert [r[0] for r in rows[1:]] == list(study["candidates"])
    for row in rows[1:]:
        candidate = study["candidates"][row[0]]
        assert agrees(row[1], candidate["max_error"]), row
        assert agrees(row[3], candidate["solve_cpu_s"]), row
        assert int(row[4]) == sum(candidate["n_steps"].values()), row
        assert (row[5] == "yes") == candidate["meets"], row


def test_chebyshev_tstar_against_the_linear_solver():
    """The t* table of benchmarks/cheb_krylov.py: every cell that the committed runs hold."""
    runs = data("benchmarks/cheb_krylov_tstar.json")["data"] + data("benchmarks/cheb_krylov_rtol.json")["data"]
    columns = {"dense LU": "dense", "band": "band", "band ε = 5e-3": "band:eps_lin=0.005",
               "band ε = 5e-4": "band:eps_lin=0.0005", "lagged dense": "lagged"}
    rows = table_after(page("chebyshev.md"), "### t* against the linear solver and the Krylov tolerance")
    head, checked = rows[0], 0
    for row in rows[1:]:
        N, rtol = int(row[0]), float(row[1].split("/")[0])
        for name, quoted in zip(head[2:], row[2:]):
            held = [r["t_star"] for r in runs if (r["N"], r["solver"]) == (N, columns[name])
                    and math.isclose(r["rtol"], rtol)]
            if quoted and held:
                assert any(agrees(quoted, t) for t in held), (N, rtol, name, quoted, held)
                checked += 1
    assert checked >= 15


def test_grid_convergence_table():
    rows = table_after(page("results.md"), "**Grid convergence**")
    Ns = rows[0][1:]
    for label, scheme in (("error, upwind (default)", "upwind"), ("error, `--advection central`", "central")):
        study = data(f"convergence/icidr_sine_{scheme}.json")
        i = next(k for k, r in enumerate(rows) if r[0] == label)
        for n, quoted in zip(Ns, rows[i][1:]):
            assert agrees(quoted, study["errors"][n]), (scheme, n)
        for quoted, order in zip(rows[i + 1][2:], study["orders"]):
            assert agrees(quoted, order), (scheme, quoted)


def test_chebyshev_tstar_against_the_integrator():
    """The table of t* by scheme, method and tolerances: data/tstar/tolerance_study_N201.json."""
    runs = data("tstar/tolerance_study_N201.json")
    rows = table_after(page("chebyshev.md"), "## t* depends on the integrator")
    assert rows[0][:6] == ["scheme", "method", "Jacobian", "rtol", "atol", "t*"]
    for scheme, method, _, rtol, atol, t_star, vs_paper, _, wall in rows[1:]:
        [run] = [r for r in runs if (r["discretization"], r["method"]) == (scheme, method)
                 and math.isclose(r["rtol"], float(rtol)) and math.isclose(r["atol"], float(atol))]
        assert agrees(t_star, run["t_star"]) and agrees(wall, run["wall_s"]), (scheme, method, rtol, atol)
        if scheme == "cheb":
            assert agrees(vs_paper.replace(" ", ""), run["t_star"] / 0.01052 - 1), (method, rtol, atol)


def test_preset_tolerances_and_their_tstar_error():
    """performance.md's preset table: the tolerances are the presets', the errors those of the
    committed rtol sweep (N = 201 against the converged t*, N = 101 against its own rtol 1e-10)."""
    from icidr_pde.presets import PRESETS

    runs = data("benchmarks/cheb_krylov_rtol.json")["data"]
    converged = {201: data("reference/mui-shear-tstar-cheb.json")["t_star"],
                 101: next(r["t_star"] for r in runs if r["N"] == 101 and math.isclose(r["rtol"], 1e-10))}
    rows = table_after(page("performance.md"), "(data/benchmarks/cheb_krylov_rtol.json;")
    for preset, tolerances, *errors in rows[1:]:
        rtol, atol = (float(x) for x in tolerances.split("/"))
        cheb = {k: PRESETS[preset][k] for k in ("rtol", "atol")}
        cheb = {k: v["cheb"] if isinstance(v, dict) else v for k, v in cheb.items()}
        assert (rtol, atol) == (cheb["rtol"], cheb["atol"]), preset
        for N, quoted in zip((201, 101), errors):
            if re.fullmatch(r"[\d.e-]+", quoted):
                [t] = [r["t_star"] for r in runs if r["N"] == N and math.isclose(r["rtol"], rtol)]
                assert agrees(quoted, abs(t - converged[N]) / converged[N]), (preset, N)


def test_quoted_constants_are_the_code_s():
    """The 2-D native engine's reach and the Krylov tolerance, where the pages state them without
    naming the constant (tests/test_researcher.py checks the sentences that name it)."""
    from icidr_pde.cells import get_cell
    from icidr_pde.cvode_settings import KRYLOV_EPS_LIN

    NATIVE_FV2D_AUTO_CELLS = get_cell("plane2d").native_auto_cells

    side = math.isqrt(NATIVE_FV2D_AUTO_CELLS)
    assert side * side == NATIVE_FV2D_AUTO_CELLS
    quoted = [(name, int(n)) for name in ("sim2d.md", "scaling.md", "engines.md")
              for n in re.findall(r"(?:grids up to|runs|fv2d up to) (\d+)² (?:on the native engine|and below|=)",
                                  page(name))]
    assert quoted and all(n == side for _, n in quoted), quoted
    for name in ("sim2d.md", "scaling.md"):
        for number in re.findall(r"eps_lin (\S+) \(the default", page(name)):
            assert agrees(number.rstrip(","), KRYLOV_EPS_LIN), (name, number)


def native2d_runs(*names):
    runs = {}
    for name in names:
        runs.update(data(f"benchmarks/{name}.json")["runs"])
    return runs


def check_native_against_pypde(rows, runs):
    """Rows "| 64² | a / b | ratio | a / b | ratio | a / b | ratio | steps / steps | ..." of native2d_speed.py."""
    head = rows[0]
    assert head[1:8] == ["process native / py-pde [s]", "ratio", "process CPU native / py-pde [s]", "ratio",
                         "solve native / py-pde [s]", "ratio", "steps native / py-pde"], head
    for row in rows[1:]:
        run = runs[row[0].rstrip("²")]
        for cell, ratio, key in ((row[1], row[2], "process_s"), (row[3], row[4], "process_cpu_s"),
                                 (row[5], row[6], "solve_s")):
            native, pde = cell.split(" / ")
            assert agrees(native, run["native"][key]) and agrees(pde, run["pde"][key]), (row[0], key)
            assert agrees(ratio, run["native"][key] / run["pde"][key]), (row[0], key)
        assert row[7] == f"{run['native']['n_steps']} / {run['pde']['n_steps']}", row[0]


def test_native2d_tables_and_the_reach_of_auto():
    """engines.md's two tables of benchmarks/native2d_speed.py, and Plane2D.native_auto_cells: `auto`
    takes the native engine on the grids where it measured faster whole-process than the py-pde
    default (the x-Fourier run), and not beyond."""
    from icidr_pde.cells import get_cell

    NATIVE_FV2D_AUTO_CELLS = get_cell("plane2d").native_auto_cells
    text = page("engines.md")
    check_native_against_pypde(table_after(text, "2 December 2026 on the shared 2-core machine at load 2.8-3.7"),
                               native2d_runs("native2d_speed", "native2d_speed_96"))
    fourier = native2d_runs("native2d_speed_fourier")
    check_native_against_pypde(table_after(text, "(`--sizes 32 48 64 96 --rhs-sizes --json"), fourier)
    for n, run in fourier.items():
        faster = run["native"]["process_s"] < run["pde"]["process_s"]
        assert faster == (int(n) ** 2 <= NATIVE_FV2D_AUTO_CELLS), n
    rhs = data("benchmarks/native2d_speed.json")["rhs"]
    for grid, c, numba, ratio, _ in table_after(text, "The right-hand side alone at the initial state")[1:]:
        r = rhs[grid.rstrip("²")]
        assert agrees(c, r["c_us"]) and agrees(numba, r["numba_us"]) and agrees(ratio, r["c_us"] / r["numba_us"]), grid


# --- 2-D (docs/results.md, docs/sim2d.md) -----------------------------------------------------


def gallery():
    return json.loads((DOCS / "figures" / "numbers.json").read_text())


def test_results_two_d_numbers():
    text = page("results.md")
    polar, bump = gallery()["figures"]["polar2d"], gallery()["figures"]["bump2d"]
    lo, hi = polar["mui_ill_posed_intervals_deg"][0]
    m = re.search(r"ill-posed for θ ∈ \(([\d.]+)°, ([\d.]+)°\), worst (\d+)° \(Λ = ([\d.]+)\), while\s+"
                  r"the 1-D direction θ = 90° has Λ\+ = (\S+)\.", text)
    assert m, "results.md: the steady-shear sentence changed; update this test with it"
    assert agrees(m.group(1), lo) and agrees(m.group(2), hi) and float(m.group(3)) == polar["mui_worst_angle_deg"]
    assert agrees(m.group(4), polar["mui_max_lambda"]) and agrees(m.group(5), polar["mui_lambda_at_90_deg"])
    m = re.search(r"interval \(([\d.]+)°, ([\d.]+)°\) equals the closed form .* to (\S+)°", text)
    assert agrees(m.group(1), lo) and agrees(m.group(2), hi)
    assert agrees(m.group(3), polar["interval_endpoint_difference_deg"])
    m = re.search(r"98 % of its t\* = ([\d.]+) against iCIDR at the same time; (\d+) % of φ's spectral energy", text)
    assert agrees(m.group(1), bump["t_star_mui"]) and agrees(m.group(2) + "%", bump["mui_phi_spectrum_fraction_in_ill_posed_cone"])
    assert agrees("98%", bump["t_shown_over_t_star"])
    t_star_64 = next(r["t_star_2d"] for r in data("sim2d/tstar.json")["rows"] if r["N"] == 64)
    assert agrees(m.group(1), t_star_64)


def test_sim2d_tables_are_the_studies_tables():
    """docs/sim2d.md holds the tables `icidr-pde study sim2d tables` prints from data/sim2d."""
    from icidr_pde.studies import sim2d

    text = page("sim2d.md")
    for render, name in ((sim2d.tstar_table, "tstar"), (sim2d.convergence_table, "convergence"),
                         (sim2d.growth_table, "mode_growth")):
        table = render(data(f"sim2d/{name}.json")).strip()
        assert table in text, f"docs/sim2d.md: the {name} table is not what data/sim2d/{name}.json gives"
    for name, render in (("tstar_large", sim2d.tstar_table), ("convergence_large", sim2d.convergence_table)):
        if (DATA / "sim2d" / f"{name}.json").is_file():  # the grids beyond 128^2, once committed
            table = render(data(f"sim2d/{name}.json")).strip()
            assert table in text, (f"docs/sim2d.md: the {name} table is not what data/sim2d/{name}.json gives "
                                   "(`icidr-pde study sim2d tables` prints it)")
    t_star_64 = next(r["t_star_2d"] for r in data("sim2d/tstar.json")["rows"] if r["N"] == 64)
    assert agrees(re.search(r"fails at t\* ≈ ([\d.]+)", text).group(1), t_star_64)


def test_sim2d_richardson_tables():
    text, study = page("sim2d.md"), data("sim2d/richardson.json")
    for scheme, marker in (("central", "Central advection:"), ("upwind", "Upwind advection:")):
        rows = table_after(text, marker)
        for measure, t, order, *errors in rows[1:]:
            fit = study["schemes"][scheme][measure][t]
            assert agrees(order, fit["order"]), (scheme, measure, t)
            for quoted, error in zip(errors, fit["rel_error"]):
                assert agrees(quoted, error), (scheme, measure, t, quoted)


# --- the gallery (docs/figures) ---------------------------------------------------------------


def test_gallery_page_is_written_from_its_numbers(tmp_path):
    from icidr_pde.figures.gallery import write_gallery

    numbers = gallery()
    written = write_gallery(numbers["figures"], tmp_path, numbers.get("movies") or None, numbers["meta"])
    assert written.read_text() == (DOCS / "figures" / "README.md").read_text(), (
        "docs/figures/README.md is not the page `icidr-pde figures` writes from docs/figures/numbers.json")


def test_gallery_numbers_that_quote_committed_data_are_that_data():
    """The gallery's entries drawn from committed studies carry those studies' numbers."""
    figures = gallery()["figures"]
    committed = {str(r["N"]): r["t_star_2d"] for r in data("sim2d/tstar.json")["rows"]}
    assert figures["tstar2d"]["t_star_2d"] == committed
    large = DATA / "sim2d" / "tstar_large.json"  # the grids beyond 128^2 where committed, else none drawn
    assert figures["tstar2d"]["large_t_star_2d"] == {str(r["N"]): r["t_star_2d"] for r in (
        data("sim2d/tstar_large.json")["rows"] if large.is_file() else []) if r["t_star_2d"] is not None}, (
        "docs/figures: tstar2d is not drawn from data/sim2d/tstar_large.json: icidr-pde figures --only tstar2d")
    large = DATA / "sim2d" / "convergence_large.json"
    assert figures["tstar2d"]["large_max_w"] == (
        {n: run["max_w"] for n, run in data("sim2d/convergence_large.json")["runs"].items()} if large.is_file() else {})
    assert figures["tstar2d"]["t_star_1d_fails_from_N"] == min(
        r["N"] for r in data("sim2d/tstar.json")["rows"] if r["t_star_1d"] is not None)
    assert figures["fig4"]["cheb_t_star_N201_data"] == tstar_sweep(TSTAR_STATED, "cheb")[201]
    assert figures["fig4"]["cheb_threshold_N"] == first_failing_N(tstar_sweep(TSTAR_STATED, "cheb"))
    # the fresh runs of the gallery agree with the committed ones to the digits the pages quote
    assert agrees(f"{committed['64']:.4g}", figures["bump2d"]["t_star_mui"])


# --- the measurement pages: each table that names a command is checked or a dated record -----

MEASUREMENT_PAGES = ("chebyshev.md", "performance.md", "scaling.md", "engines.md", "results.md", "sim2d.md",
                     "distributed.md")
#: the tables of those pages checked above, by a line of their introduction
CHECKED = {"chebyshev.md": ("### t* against the linear solver and the Krylov tolerance",
                            "BDF (scipy), rtol = 1e-6, analytic Jacobian", "## t* depends on the integrator",
                            "load of the run):"),
           "performance.md": ("(data/benchmarks/cheb_krylov_rtol.json;",),
           "engines.md": ("2 December 2026 on the shared 2-core machine at load 2.8-3.7",
                          "(`--sizes 32 48 64 96 --rhs-sizes --json", "The right-hand side alone at the initial state"),
           "results.md": ("data/tstar/mui_shear_fd_BDF_rtol1e-6_atol1e-9.json;", "**Grid convergence**"),
           "sim2d.md": ("`icidr-pde study sim2d tstar`", "**max_w**", "**max_phi_dev**", "**l2_velocity**",
                        "Central advection:", "Upwind advection:", "`icidr-pde study sim2d growth`",
                        "(data/sim2d/tstar_large.json)")}
#: "*Dated record*: `command`[ how it ran], YYYY-MM-DD[ time], machine and load[; data file]"
RECORD = re.compile(r"^\*Dated record\*: `(?P<command>[^`]+)`[^,`]*, (?P<date>\d{4}-\d{2}-\d{2})(?: [^,]*)?, "
                    r"(?P<machine>.*machine.*)$")
#: a command, in backticks or on a line of its own (a code block)
COMMAND = re.compile(r"(?:`|^\s*)((?:[A-Z_]+=\S+ )*(?:nice -n \d+ )?(?:python3? (?:-m \S+|benchmarks/\S+)|icidr-pde \w)[^`\n]*)",
                     re.MULTILINE)


DELIMITER = re.compile(r"^\|?\s*:?-{3,}:?\s*(\|\s*:?-{3,}:?\s*)*\|?\s*$")


def tables_and_introductions(text: str):
    """(first line, text since the previous table or heading, text of its section) of each table.

    A table is a line starting with | followed by a delimiter row. A section starts at a heading
    of level 1 or 2: a command or record stated at its top holds for the tables of its subsections."""
    lines = text.splitlines()
    out, local, section, in_table, fence = [], [], [], False, False
    for k, line in enumerate(lines):
        if line.startswith("```"):
            fence = not fence
        starts = not fence and line.startswith("|") and k + 1 < len(lines) and DELIMITER.match(lines[k + 1])
        if starts and not in_table:
            out.append((line, "\n".join(local), "\n".join(section)))
            in_table, local = True, []
            continue
        if in_table and line.startswith("|"):
            continue
        in_table = False
        if not fence and re.match(r"#{1,2} ", line):
            section = []
        if not fence and line.startswith("#"):
            local = []
        local.append(line)
        section.append(line)
    return out


def command_exists(command: str) -> bool:
    """The benchmark file or `python -m` module a command runs is there (the console script is;
    ``python -`` and ``python -c`` run the code the page shows)."""
    words = [w for w in shlex.split(command) if not re.match(r"[A-Z_]+=", w)]
    while words and (words[0] in ("nice", "mpiexec", "-n") or words[0].isdigit() or words[0] == "P"):
        words = words[1:]
    if not words:
        return False
    if words[0] == "icidr-pde":
        from icidr_pde.cli import SUBCOMMANDS

        return len(words) > 1 and (words[1] in SUBCOMMANDS or words[1].startswith("-"))
    if words[0].startswith("python") and len(words) > 1:
        if words[1] == "-m":
            import importlib.util

            return importlib.util.find_spec(words[2]) is not None
        if words[1] in ("-", "-c"):
            return True
        return (ROOT / words[1]).is_file()
    return False


@pytest.mark.parametrize("name", MEASUREMENT_PAGES)
def test_measured_tables_are_checked_or_dated_records(name):
    problems = []
    for first, local, section in tables_and_introductions(page(name)):
        if not COMMAND.search(section) or any(marker in local for marker in CHECKED.get(name, ())):
            continue
        records = [RECORD.match(line) for line in section.splitlines() if line.startswith("*Dated record*")]
        if not records or not records[-1]:
            problems.append(f"{name}: the table {first[:60]!r} names a command but is neither checked by "
                            "tests/test_doc_numbers.py nor marked '*Dated record*: `command`, YYYY-MM-DD, machine'")
        elif not command_exists(records[-1]["command"]):
            problems.append(f"{name}: the dated record {records[-1]['command']!r} names a command that is gone")
    assert not problems, "\n".join(problems)


def test_commands_the_pages_name_exist():
    """Every `python -m MODULE` and `python benchmarks/FILE` a page names can still be run."""
    gone = []
    for path in sorted(DOCS.glob("**/*.md")):
        if "_build" in path.parts or "api" in path.relative_to(DOCS).parts[:1]:
            continue
        for command in re.findall(r"python3? (-m [\w.]+|benchmarks/[\w./]+\.py)", path.read_text()):
            if not command_exists("python " + command):
                gone.append(f"{path.relative_to(ROOT)}: python {command}")
    assert not gone, "commands named in docs/ that no longer exist:\n" + "\n".join(sorted(set(gone)))


def test_source_files_the_pages_name_exist():
    """Every source file a page names in backticks (`icidr_pde/cells/plane2d/native.py`) is there."""
    named = re.compile(r"`((?:icidr_pde|stability|benchmarks|tests|examples)/[\w/.]+\.(?:py|c|h|toml))`")
    gone = sorted({f"{path.relative_to(ROOT)}: {name}" for path in [ROOT / "README.md", *sorted(DOCS.glob("*.md"))]
                   for name in named.findall(path.read_text()) if not (ROOT / name).exists()})
    assert not gone, "files named in the pages that do not exist:\n" + "\n".join(gone)


def test_record_check_can_fail():
    text = "Intro (`python benchmarks/startup.py`):\n\n| a | b |\n|---|---|\n| 1 | 2 |\n"
    [(first, local, section)] = tables_and_introductions(text)
    assert COMMAND.search(section) and not any(RECORD.match(line) for line in section.splitlines())
    assert RECORD.match("*Dated record*: `python benchmarks/startup.py --repeats 3`, 2026-12-01, shared 2-core machine, load 0.8")
    assert not command_exists("python benchmarks/no_such_benchmark.py")
    assert not command_exists("python -m icidr_pde.no_such_module")
    assert not command_exists("icidr-pde no-such-subcommand")
    assert command_exists('PETSC_OPTIONS="-pc_type gamg" mpiexec -n 2 icidr-pde run --engine petsc')
    assert command_exists("OMP_NUM_THREADS=1 nice -n 5 python benchmarks/shortwave2d.py --sizes 256")
