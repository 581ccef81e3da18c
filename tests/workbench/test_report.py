"""The workbench report against independent truth: (A18), the plane-wave closed forms of
stability.plane, the paper's statements about (4.3)-(4.5), and measured growth rates."""

import json
import pathlib

import numpy as np
import pytest

from icidr_pde.cli import main
from icidr_pde.rheology import chi, get_rheology
from stability import workbench as wb

EXAMPLE = pathlib.Path(__file__).resolve().parents[2] / "examples" / "half_rate_law.py"


@pytest.fixture(scope="module")
def reports():
    return {name: wb.law_report(name, with_curves=False) for name in ("icidr", "mui", "mu-psi")}


def test_icidr_conditions_hold_symbolically(reports):
    r = reports["icidr"]
    assert {k: (c["status"], c["method"]) for k, c in r["conditions"].items()} == {
        "(4.3)": ("holds", "symbolic"), "(4.4)": ("holds", "symbolic"), "(4.5)": ("holds", "symbolic")}
    assert r["well_posed"] is True and r["conditions_hold"] is True
    assert r["stability"]["one_d"]["well_posed"] and r["stability"]["two_d"]["well_posed"]


def test_mu_psi_violates_4_4_as_section_4_says(reports):
    c = reports["mu-psi"]["conditions"]
    assert c["(4.4)"]["status"] == "fails" and c["(4.4)"]["method"] == "symbolic"
    assert c["(4.4)"]["counterexample"]["value"] == 0.0           # dY/dI = 0 identically
    assert c["(4.3)"]["status"] == "holds" and c["(4.5)"]["status"] == "holds"
    assert reports["mu-psi"]["well_posed"] is False and reports["mu-psi"]["runnable"] is False


def test_mui_is_not_a_cidr_law_and_ill_posed(reports):
    r = reports["mui"]
    assert all(c["status"] == "not applicable" for c in r["conditions"].values())
    assert r["well_posed"] is False and r["conditions_hold"] is None


def test_mui_one_d_verdict_is_chi(reports):
    """1-D ill-posed states of mu(I),Phi(I) are exactly those with chi > 0 (A18)."""
    r = get_rheology("mui")
    grid = wb.symbol_grid(r)
    S = grid.rate / 2
    wz = grid.ratio * S
    uz = np.sqrt(np.maximum(4 * S**2 - wz**2, 0))
    ok = uz > 0
    expected = chi(grid.phi[ok], uz[ok], wz[ok]) > 0
    np.testing.assert_array_equal(grid.ill_posed_1d()[ok], expected)
    # 2-D: eig(-Gamma) ~ cos 2(theta - beta) - M > 0 near theta = beta for every M < 1 (stability.plane)
    assert grid.ill_posed_2d().all()


def test_icidr_plane_waves_match_the_closed_form():
    """Lambda_max(theta) = -2 (R - div u)/(phi Psi^2) for every theta (stability.plane, d = rho_* = 1)."""
    r = get_rheology("icidr")
    phi = np.array([0.6, 0.78, 0.81, 0.78])
    div = np.array([0.0, 0.1, -0.2, 0.05])
    S = np.array([0.5, 0.02, 0.3, 1e-3])
    G = wb.plane_gamma(r, phi, div, S, np.linspace(0, 180, 19))
    lp, _ = wb._eig_minus_gamma(G)
    M, Psi = r.material.M(phi), r.material.Psi(phi)
    R = np.sqrt(div**2 + M**2 * S**2)
    expected = -2 * (R - div) / (phi * Psi**2)
    np.testing.assert_allclose(lp.real, np.broadcast_to(expected[:, None], lp.shape), rtol=1e-10)


@pytest.mark.parametrize("name", ["icidr", "mui", "icidr-blended"])
def test_one_d_gamma_is_plane_gamma_at_90_degrees(name):
    """The shear-cell Gamma (A5) from the shear-cell kernels equals Gamma(n = e_z) from the invariant kernels."""
    r = get_rheology(name)
    phi, uz = np.array([0.7, 0.8, 0.81]), np.array([0.4, 1 / 30, 2.0])
    G1 = wb.one_d_gamma(r, phi, uz, 0 * uz)
    G2 = wb.plane_gamma(r, phi, 0 * uz, uz / 2, [90.0])[:, 0]
    np.testing.assert_allclose(G1, G2, rtol=1e-10, atol=1e-12 * np.abs(G1).max())


def test_kernel_gamma_agrees_with_the_sympy_toolkit():
    from stability.numeric import stability_numbers

    r = get_rheology("icidr-nonmonotonic")
    for state in [(0.815, 1 / 30, 0.05), (0.79, 1.0, -0.3)]:
        sn = stability_numbers("icidr-nonmonotonic", *state, material=r.material)
        G = wb.one_d_gamma(r, *(np.array([v]) for v in state))[0]
        assert np.trace(G) == pytest.approx(sn.trace_gamma, rel=1e-10)
        assert np.linalg.det(G) == pytest.approx(sn.det_gamma, rel=1e-9)


def test_nonmonotonic_friction_measured_growth_is_the_symbol():
    """Where friction decreases (phi = 0.815): measured single-mode growth at xi = 30 is max Re eig A(xi)."""
    from stability.growth import measured_growth_rate

    for name in ("mui-nonmonotonic", "icidr-nonmonotonic"):
        g = measured_growth_rate(name, 0.815, 1 / 30, 0.05, xi=30.0, material=get_rheology(name).material)
        assert g["rel_error"] < 1e-6, g


@pytest.mark.slow
def test_nonmonotonic_friction_growth_measured_against_the_symbol():
    """Where friction decreases (phi = 0.815, I = 0.0064 < 0.0124), single Fourier modes of the
    linearised equations: mu(I),Phi(I) with this mu grows like Lambda_+ xi^2 (ill-posed: no bound
    as xi -> oo); iCIDR with it tends to the bounded lambda_0 = -C/B (well-posed)."""
    from stability.growth import measured_growth_rate
    from stability.numeric import stability_numbers

    state = (0.815, 1 / 30, 0.05)
    rates = {}
    for name in ("mui-nonmonotonic", "icidr-nonmonotonic"):
        mat = get_rheology(name).material
        sn = stability_numbers(name, *state, material=mat)
        for xi in (30.0, 300.0):
            g = measured_growth_rate(name, *state, xi=xi, material=mat)
            assert g["rel_error"] < 1e-6, g                      # measured = max Re eig A(xi)
            rates[name, xi] = g["measured"]
        rates[name] = sn
    lp = rates["mui-nonmonotonic"].lambda_plus.real
    assert lp > 0 and rates["mui-nonmonotonic", 300.0] / 300.0**2 == pytest.approx(lp, rel=0.05)
    assert rates["icidr-nonmonotonic"].lambda_plus.real < 0
    assert rates["icidr-nonmonotonic", 300.0] == pytest.approx(rates["icidr-nonmonotonic"].lambda0_limit, rel=0.05)


def test_law_check_cli_json_schema(tmp_path, capsys):
    out = tmp_path / "icidr.json"
    assert main(["law", "check", "icidr", "--json", str(out), "--no-curves"]) == 0
    data = json.loads(out.read_text())
    assert data["law"] == "icidr" and data["well_posed"] is True
    assert set(data["conditions"]) == {"(4.3)", "(4.4)", "(4.5)"}
    for c in data["conditions"].values():
        assert c["status"] in ("holds", "fails") and c["method"] in ("symbolic", "sampled")
        assert "counterexample" in c
    assert "verdict: WELL-POSED" in capsys.readouterr().out


def test_law_list_and_bad_names(capsys):
    assert main(["law", "list"]) == 0
    listed = capsys.readouterr().out
    for name in ("icidr", "mui", "mu-psi", "icidr-nonmonotonic", "icidr-saturating-phi", "icidr-blended"):
        assert name in listed
    assert main(["law", "check", "no-such-law"]) == 2
    assert "`rheology` must be one of" in capsys.readouterr().err
    assert main(["law", "check", "missing_file.py"]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_user_law_file_is_checked(tmp_path):
    r = wb.law_report(str(EXAMPLE), with_curves=False)
    assert r["law"] == "half-rate" and r["well_posed"] is True
    assert all(c["status"] == "holds" for c in r["conditions"].values())


def test_sampled_condition_reports_a_counterexample_and_region():
    """The half-power blended law: (4.4) cannot be decided by sympy; the sample finds where dY/dI < 0."""
    r = get_rheology("icidr-blended-half")
    c = wb.check_conditions(r)
    assert c["(4.3)"].status == "holds"
    c44 = c["(4.4)"]
    assert c44.method == "sampled" and c44.status == "fails" and c44.counterexample["value"] < 0
    assert 0 < c44.region["fraction_of_sample"] < 0.5


@pytest.mark.parametrize("name", ["icidr-nonmonotonic", "mui", pytest.param("icidr-blended", marks=pytest.mark.slow),
                                  "mu-psi", pytest.param("icidr-blended-quarter", marks=pytest.mark.slow)])
def test_plane_gamma_agrees_with_the_directional_toolkit(name):
    """2-D Lambda_max(theta) from the generated invariant kernels = stability.directional's (sympy principal part)."""
    from stability.directional import directional_stability

    r = get_rheology(name)
    angles = np.arange(0.0, 180.0, 15.0)
    for phi, div, s in ((0.8, 0.0, 0.4), (0.75, -0.1, 0.2)):
        L = (div / 2, s, s, div / 2)                      # grad u = [[d/2, s], [s, d/2]]: S = s [[0,1],[1,0]]
        ref = directional_stability(r, phi, L, angles_deg=angles, material=r.material)
        lp, _ = wb._eig_minus_gamma(wb.plane_gamma(r, np.array([phi]), np.array([div]), np.array([s]), angles))
        np.testing.assert_allclose(lp[0].real, ref.lambda_max, rtol=1e-9, atol=1e-12 * np.abs(ref.lambda_max).max())
