"""``icidr-pde study sim2d convergence|tstar`` with the integrator settings given (--rtol, --atol,
--jacobian): the runs of the study are the runs of :func:`icidr_pde.api.run` at those settings,
the JSON's "command" reruns the study to the same numbers, the committed data/sim2d files carry
the command of their settings, and bad values are refused in one line before any run.

Truth used: direct runs of the run path at the settings asked for (and at the study's defaults,
which give other numbers: the test can fail), and the command field executed again.
"""

import json
import pathlib
import shlex

import pytest

from icidr_pde import run
from icidr_pde.cli import main
from icidr_pde.studies import sim2d

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "sim2d"
#: the settings of the grids beyond 128^2 (docs/sim2d.md): the stable 2-D default of `run`
LARGE = ["--rtol", "1e-5", "--atol", "1e-8", "--jacobian", "fourier"]
LARGE_SETTINGS = {"method": "CVODE", "rtol": 1e-5, "atol": 1e-8, "jacobian": "fourier"}


def _study(tmp_path, argv):
    assert main(["study", "sim2d", *argv, "--no-progress"]) == 0
    return json.loads((tmp_path / argv[argv.index("--json") + 1]).read_text())


def _rerun(tmp_path, payload, folder):
    """The payload's command executed in `folder` (its --json relative there): the JSON it writes."""
    words = shlex.split(payload["command"])
    assert words[:3] == ["icidr-pde", "study", "sim2d"]
    (tmp_path / folder).mkdir()
    return _study(tmp_path / folder, [*words[3:-1], str(tmp_path / folder / words[-1])])


def _without_wall(runs: dict) -> dict:
    return {n: {k: v for k, v in r.items() if k != "wall_s"} for n, r in runs.items()}


def test_convergence_takes_the_settings_given_and_its_command_reruns_it(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    payload = _study(tmp_path, ["convergence", "--sizes", "8", *LARGE, "--json", "c.json"])
    assert payload["settings"] == LARGE_SETTINGS
    assert payload["command"] == ("icidr-pde study sim2d convergence --sizes 8 --rtol 1e-05 --atol 1e-08 "
                                  "--jacobian fourier --json c.json")
    times = list(sim2d.TIMES)
    direct = run("icidr", "bump2d", (8, 8), 10.0, times, **LARGE_SETTINGS)
    assert direct.to_dict()["jacobian"] == "fourier" and direct.to_dict()["rtol"] == 1e-5
    for q in sim2d.QUANTITIES:
        assert payload["runs"]["8"][q] == direct.to_dict()[q], q
    default = run("icidr", "bump2d", (8, 8), 10.0, times, **{**sim2d.SOLVER_2D, **sim2d.SETTINGS})
    assert default.to_dict()["max_w"] != payload["runs"]["8"]["max_w"]  # the options changed the runs
    again = _rerun(tmp_path, payload, "again")
    assert _without_wall(again["runs"]) == _without_wall(payload["runs"]) and again["settings"] == payload["settings"]


def test_tstar_takes_the_settings_given_in_2d_and_its_command_reruns_it(tmp_path, monkeypatch):
    """The 2-D run takes --jacobian; the x-independent 1-D run (fd) the tolerances with its own Jacobian."""
    monkeypatch.chdir(tmp_path)
    payload = _study(tmp_path, ["tstar", "--sizes", "8", *LARGE, "--json", "t.json"])
    assert payload["settings"] == LARGE_SETTINGS
    assert payload["command"] == ("icidr-pde study sim2d tstar --sizes 8 --rtol 1e-05 --atol 1e-08 "
                                  "--jacobian fourier --json t.json")
    [row] = payload["rows"]
    two_d = run("mui", "bump2d", (8, 8), 10.0, ["0", "10"], series_times=[], **LARGE_SETTINGS)
    assert two_d.blew_up and row["t_star_2d"] == two_d.t_star
    defaults = _study(tmp_path, ["tstar", "--sizes", "8", "--json", "d.json"])
    assert defaults["settings"] == sim2d.SETTINGS
    assert defaults["command"] == "icidr-pde study sim2d tstar --sizes 8 --json d.json"
    assert defaults["rows"][0]["t_star_2d"] != row["t_star_2d"]
    again = _rerun(tmp_path, payload, "again")
    assert again["rows"] == payload["rows"]


def test_a_command_without_options_is_the_studies_own():
    """The defaults leave the case settings (the cache keys) and the command as they were."""
    assert sim2d.study_command("convergence", dict(sim2d.SETTINGS), sim2d.SIZES, sim2d.SIZES,
                               sim2d.DATA / "convergence.json", sim2d.DATA / "convergence.json") \
        == "icidr-pde study sim2d convergence"
    # an explicit default is no option: the same runs
    assert sim2d.study_command("tstar", {**sim2d.SETTINGS, "rtol": 1e-7, **sim2d.SOLVER_2D}, [16, 24, 32, 48, 64, 96, 128],
                               sim2d.TSTAR_SIZES, "data/sim2d/tstar.json", sim2d.DATA / "tstar.json") \
        == "icidr-pde study sim2d tstar"


@pytest.mark.parametrize("name, part", [("convergence.json", "convergence"), ("convergence_upwind.json", "convergence"),
                                        ("tstar.json", "tstar")])
def test_the_committed_studies_are_rerun_by_the_command_of_their_settings(name, part):
    """Their command (written as ``python -m icidr_pde.studies.sim2d ...`` before the ``study``
    subcommand) is the one the present code writes for their settings: no option beyond theirs."""
    payload = json.loads((DATA / name).read_text())
    sizes = payload["sizes"] if part == "convergence" else [r["N"] for r in payload["rows"]]
    default_sizes = sim2d.SIZES if part == "convergence" else sim2d.TSTAR_SIZES
    default_path = sim2d.DATA / ("convergence_upwind.json" if "advection" in payload["settings"] else f"{part}.json")
    command = payload["command"].replace("python -m icidr_pde.studies.sim2d", "icidr-pde study sim2d")
    assert command == sim2d.study_command(part, payload["settings"], sizes, default_sizes,
                                                     sim2d.DATA / name, default_path)


def test_the_help_states_the_studies_defaults(capsys):
    """The parser names the defaults without importing the study module: they must be its values."""
    with pytest.raises(SystemExit):
        main(["study", "sim2d", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"the study's, {sim2d.SETTINGS['rtol']!r}:" in text and f"the study's, {sim2d.SETTINGS['atol']!r}:" in text
    assert f"the study's, {sim2d.SOLVER_2D['jacobian']!r}:" in text


@pytest.mark.parametrize("argv, option", [
    (["convergence", "--rtol", "0"], "`--rtol`"),
    (["tstar", "--rtol", "2"], "`--rtol`"),
    (["convergence", "--rtol", "nan"], "`--rtol`"),
    (["tstar", "--atol=-1e-08"], "`--atol`"),
    (["convergence", "--rtol", "tight"], "--rtol"),
    (["tstar", "--jacobian", "dense"], "--jacobian"),
    (["growth", "--rtol", "0.001"], "`--rtol`"),
    (["convergence", "--engine", "petsc", "--jacobian", "fourier"], "`--jacobian`"),
])
def test_bad_settings_are_refused_in_one_line_before_any_run(argv, option, tmp_path, capsys):
    json_path = tmp_path / "out.json"
    try:
        code = main(["study", "sim2d", *argv, "--sizes", "8", "--json", str(json_path), "--no-progress"])
    except SystemExit as stop:  # argparse's refusal
        code = stop.code
    assert code == 2
    captured = capsys.readouterr()
    errors = [line for line in captured.err.splitlines() if "error" in line]  # argparse prints its usage too
    assert len(errors) == 1 and option in errors[0] and "Traceback" not in captured.err, captured.err
    given = " ".join(argv[1:]).replace("=", " ").split()
    value = given[given.index(option.strip("`")) + 1]
    assert f"got {value}" in errors[0] or f"'{value}'" in errors[0] or f"{option.strip('`')} {value}" in errors[0], \
        errors[0]
    assert "iCIDR bump2d" not in captured.out and "mu(I) bump2d" not in captured.out  # no run started
    assert not json_path.exists()


def test_grids_run_apart_combine_into_the_study_run_together(tmp_path):
    """combine_studies: the JSON of 8^2 and 16^2 run apart is the JSON of both run together (orders,
    command) but the wall times; parts of different settings are refused."""
    times = ("0.05", "0.1")
    together = sim2d.convergence_study((8, 16, 32), times, path=tmp_path / "c.json")
    parts = [sim2d.convergence_study((n,), times, path=tmp_path / f"c{n}.json") for n in (32, 8, 16)]
    combined = sim2d.combine_studies([tmp_path / "c32.json", parts[1], tmp_path / "c16.json"], tmp_path / "c.json")
    assert _without_wall(combined.pop("runs")) == _without_wall(together.pop("runs"))
    assert combined == together and json.loads((tmp_path / "c.json").read_text())["sizes"] == [8, 16, 32]
    rows = [sim2d.tstar_study((n,), 0.1, path=tmp_path / f"t{n}.json") for n in (12, 8)]
    assert sim2d.combine_studies(rows, tmp_path / "t.json") == sim2d.tstar_study((8, 12), 0.1, path=tmp_path / "t.json")
    other = sim2d.convergence_study((8,), times, path=tmp_path / "o.json", rtol=1e-6)
    with pytest.raises(ValueError, match="`parts` must be grids of one study: settings"):
        sim2d.combine_studies([parts[0], other], tmp_path / "x.json")
