"""The paper's findings (§3, §5, figs 3, 4, 6, 7) reproduced with finite volumes."""

import json

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde.cli import main


@pytest.fixture(scope="module")
def icidr_shear():
    return {N: run("icidr", "shear", N, 10.0, [0, 0.5, 1, 2, 5, 10]) for N in (47, 201)}


@pytest.fixture(scope="module")
def icidr_sine():
    return {N: run("icidr", "sine", N, 20.0, [0, 1, 2, 3, 5, 10, 20]) for N in (47, 201)}


def test_mui_coarse_grid_decays_to_steady_shear():
    """Fig 3(c)/4(a): N = 47 hides the ill-posedness behind numerical diffusion."""
    res = run("mui", "shear", 47, 10.0, [0, 10])
    assert not res.blew_up
    assert res.max_w_series[-1] < 0.05 * res.max_w_series[0]
    np.testing.assert_allclose(res.u[-1], res.z / 30.0, atol=3e-3)  # close to (3.10)
    np.testing.assert_allclose(res.phi[-1], 0.78, atol=3e-3)


def test_mui_fails_sooner_as_the_grid_is_refined():
    """Figs 3(a), 4: N = 201 fails before t = 0.1 and t* falls as N grows."""
    t_star = {}
    for N in (101, 151, 201):
        res = run("mui", "shear", N, 1.0, [0])
        assert res.blew_up, N
        t_star[N] = res.t_star
    assert t_star[201] < 0.1
    assert t_star[101] > t_star[151] > t_star[201]


def test_mui_sine_fails_even_on_coarse_grid():
    """§5: with IC (5.7) chi is infinite at two points; mu(I) fails even at N = 47."""
    res = run("mui", "sine", 47, 20.0, [0])
    assert res.blew_up and res.t_star < 20.0
    assert np.isinf(res.chi[0]).any() or (res.chi[0] > 0).any()  # fig 7(d)


def assert_grids_agree(coarse, fine, tolerance):
    """Both runs finish; at every snapshot w of N = 47 matches N = 201 (interpolated) to
    `tolerance` times the initial max|w|; w decays to (3.10); mass is conserved."""
    assert not coarse.blew_up and not fine.blew_up
    w0 = np.max(np.abs(fine.w[0]))
    for k in range(1, len(fine.times)):
        assert np.max(np.abs(np.interp(coarse.z, fine.z, fine.w[k]) - coarse.w[k])) < tolerance * w0
    assert np.max(np.abs(fine.w[-1])) < 0.01 * w0  # 'very close to steady state'
    assert abs(fine.mass_drift) < 1e-8


def test_icidr_shear_is_grid_converged(icidr_shear):
    """Fig 6: N = 47 and N = 201 lie on top of one another; w decays to (3.10)."""
    assert_grids_agree(icidr_shear[47], icidr_shear[201], 0.02)


def test_icidr_sine_converges_with_local_maximum_near_3(icidr_sine):
    """Fig 7: no blow-up, grids agree, and max|w| has a local maximum near t = 3."""
    fine = icidr_sine[201]
    assert_grids_agree(icidr_sine[47], fine, 0.05)
    t, m = fine.max_w_t, fine.max_w_series
    inner = (t > 1.5) & (t < 5.0)
    k = np.argmax(np.where(inner, m, -np.inf))
    assert 2.0 < t[k] < 4.5 and m[k] > m[(t > 1.5)].min() and m[k] > m[t > t[k]].max()


def test_cli_run_json_contract(tmp_path):
    out = tmp_path / "out.json"
    assert main(["run", "--rheology", "mui", "--scene", "shear", "--N", "201", "--t-end", "1",
                 "--times", "0", "0.005", "0.50", "--json", str(out), "--no-progress"]) == 3  # failed run
    data = json.loads(out.read_text())
    for key in ("rheology", "scene", "discretization", "N", "t_end", "rtol", "atol", "blew_up",
                "t_star", "reason", "t_final", "max_w", "mass_drift", "wall_s", "n_steps",
                "n_rhs", "n_jac"):
        assert key in data
    assert data["blew_up"] and data["t_star"] < 0.1
    assert list(data["max_w"]) == ["0", "0.005"]  # labels as typed; 0.50 was not reached
    assert data["max_w"]["0"] == pytest.approx(0.05 * np.exp(-0.5) / np.sqrt(2), rel=1e-2)  # (3.16)


def test_cli_reports_bad_input(capsys):
    assert main(["run", "--rtol", "-1", "--N", "21", "--t-end", "1", "--no-progress"]) == 2
    assert "rtol" in capsys.readouterr().err
