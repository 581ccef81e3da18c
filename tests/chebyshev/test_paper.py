"""Numbers and behaviour stated in the paper (Schaeffer et al. 2019, section 3.2, fig 4)
for mu(I),Phi(I) with IC (3.16), phi0 = 0.78, eps = 0.05, H = 30, Chebyshev collocation."""

import json

import numpy as np
import pytest

from icidr_pde.studies import PAPER_TSTAR, failure_time, parse_range
from icidr_pde.cli import main as cli_main

PAPER_T_STAR = 0.01052  # fig 4(a) caption: Chebyshev N_z = 201 becomes non-convergent


# atol 1e-6 in the slow run: the same t* within 5 % at the looser absolute tolerance
@pytest.mark.parametrize("atol", [1e-9, pytest.param(1e-6, marks=pytest.mark.slow)])
def test_chebyshev_N201_fails_at_the_papers_tstar(atol):
    # BDF at rtol 1e-6 (ode15s-like); the failure is the integrator's step-size underflow
    res = failure_time("mui", "shear", "cheb", 201, 0.1, method="BDF", rtol=1e-6, atol=atol)
    assert res["t_star"] is not None, res["reason"]
    assert "integrator failed" in res["reason"]
    assert abs(res["t_star"] - PAPER_T_STAR) / PAPER_T_STAR < 0.05
    assert PAPER_TSTAR == {"N": 201, "t_star": PAPER_T_STAR}


def test_low_resolution_chebyshev_decays_without_failure():
    # fig 4(a): N_z = 47 does not blow up and decays towards the steady state (3.10)
    res = failure_time("mui", "shear", "cheb", 47, 20.0, times=[0.0, 1.0, 5.0, 10.0, 20.0])
    assert res["t_star"] is None, res["reason"]
    max_w = [np.max(np.abs(s[2])) for s in res["snapshots"]]
    assert np.all(np.diff(max_w) < 0) and max_w[-1] < 0.05 * max_w[0]


def test_failure_time_falls_as_N_grows():
    # section 3.2: higher resolution resolves faster-growing modes, failing earlier
    t = [failure_time("mui", "shear", "cheb", n, 1.0)["t_star"] for n in (101, 149, 201)]
    assert all(x is not None for x in t)
    assert t[0] > t[1] > t[2]


def test_parse_range():
    assert parse_range("21:27:2") == [21, 23, 25, 27]
    assert parse_range("21:201:2")[-1] == 201 and len(parse_range("21:201:2")) == 91
    assert parse_range("47") == [47]
    assert parse_range("201,47") == [47, 201]
    for bad in ("a:b", "21:11:2", "2", "21:31:0"):
        with pytest.raises(ValueError):
            parse_range(bad)


def test_tstar_command(tmp_path):
    out, png = tmp_path / "t.json", tmp_path / "t.png"
    code = cli_main(["tstar", "--discretization", "cheb", "--N", "21,201", "--t-end", "0.05", "--jobs", "1",
                     "--no-progress", "--json", str(out), "--plot", str(png)])
    assert code == 0
    data = json.loads(out.read_text())["discretizations"]["cheb"]["t_star"]
    assert set(data) == {"21", "201"}
    assert data["21"] is None
    assert abs(data["201"] - PAPER_T_STAR) / PAPER_T_STAR < 0.05
    assert png.stat().st_size > 1000
    assert cli_main(["tstar", "--N", "2"]) == 2  # invalid N: error code, no traceback


def test_tstar_command_on_the_native_engine(tmp_path):
    """--engine native: the native default at the standard preset's Chebyshev tolerances (rtol 1e-7):
    t* at N = 201 within 1e-3 of the converged t* of BDF rtol 1e-10 (data/reference)."""
    from icidr_pde.studies.references import reference_tstar

    out = tmp_path / "t.json"
    code = cli_main(["tstar", "--discretization", "cheb", "--N", "21,201", "--t-end", "0.05", "--jobs", "1",
                     "--engine", "native", "--no-progress", "--json", str(out)])
    assert code == 0
    data = json.loads(out.read_text())["discretizations"]["cheb"]["t_star"]
    converged = reference_tstar("cheb")["t_star"]
    assert data["21"] is None and abs(data["201"] - converged) / converged < 1e-3
    assert cli_main(["tstar", "--N", "21", "--engine", "native", "--method", "BDF"]) == 2  # CVODE only
