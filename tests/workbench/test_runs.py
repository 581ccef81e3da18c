"""Workbench laws in the simulator: the blended law across phi_c, a user law file from the CLI."""

import json
import pathlib

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde.cli import main

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "half_rate_law.py"


# on Chebyshev too in the slow run (~7 s of compilation of the law on that scheme for this test alone);
# the default run checks the law on finite volumes
@pytest.mark.parametrize("discretization", ["fd", pytest.param("cheb", marks=pytest.mark.slow)])
def test_blended_runs_beyond_phi_c_where_icidr_cannot(discretization):
    """phi0 = 0.83 > phi_c: iCIDR's pressure (4.12) is infinite there (rejected, naming phi0); the blended
    law runs, conserves mass, and the shear-cell perturbation decays."""
    res = run("icidr-blended", "shear", N=33, t_end=1.0, times=[0, 1], phi0=0.83, discretization=discretization,
              method="BDF", rtol=1e-6, atol=1e-9)
    assert not res.blew_up, res.reason
    assert abs(res.mass_drift) < 1e-10
    w = res.max_w_at_times()
    assert w["1"] < 1e-3 * w["0"]
    with pytest.raises(ValueError, match=r"`phi0` must lie in \(0, phi_c\) = \(0, 0.817\); got"):
        run("icidr", "shear", N=33, t_end=1.0, phi0=0.83, discretization=discretization)


def test_user_law_file_runs_in_the_shear_cell_from_the_cli(tmp_path, capsys):
    out = tmp_path / "run.json"
    code = main(["run", "--rheology", str(EXAMPLE), "--scene", "shear", "--accuracy", "draft", "--t-end", "1",
                 "--times", "0", "1", "--no-progress", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert data["rheology"] == "half-rate" and data["blew_up"] is False
    assert abs(data["mass_drift"]) < 1e-10 and data["max_w"]["1"] < data["max_w"]["0"]


def test_law_without_positive_pressure_cannot_be_run_from_the_cli(capsys):
    assert main(["run", "--rheology", "mu-psi", "--t-end", "0.1", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "no positive solution for p" in err and "div_u = " in err


def test_bad_rheology_argument_names_the_choices(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--rheology", "nope"])
    assert "or a law file *.toml or *.py" in capsys.readouterr().err


@pytest.mark.slow
def test_user_law_file_runs_in_the_2d_cell(tmp_path):
    out = tmp_path / "run2d.json"
    assert main(["run", "--scene", "bump2d", "--rheology", str(EXAMPLE), "--Nx", "8", "--Nz", "8", "--t-end", "1",
                 "--times", "0.5", "1", "--no-progress", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["blew_up"] is False and abs(data["mass_drift"]) < 1e-10
