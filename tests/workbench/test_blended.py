"""The blended-pressure laws (7.2)-(7.3): the quarter-power dilatancy against independent truth
(the cubic flow rule's root by mpmath, (7.2) at steady state), where each fails, and runs across phi_c."""

import mpmath
import numpy as np
import pytest

from icidr_pde.rheology import INVARIANTS, Material, get_rheology
from icidr_pde.rheology.blended import ALPHA_ITM, K_OVER_D
from stability import workbench as wb

PHI_C, A = 0.817, 0.314


def steady_P(phi, gdot):
    psi = max((PHI_C - phi) / A, 0.0)
    p_itm = ALPHA_ITM * K_OVER_D**0.75 * np.sqrt(gdot)
    return p_itm if psi == 0 else 1 / (psi**2 / gdot**2 + 1 / p_itm)


def test_quarter_law_pressure_is_the_positive_root_of_the_cubic():
    """x = (p/P)^(1/4) solves x^3 + k x^2 - 1 = 0, k = 2 div u/(M ||S||) (roots by mpmath.polyroots), across phi_c."""
    r = get_rheology("icidr-blended-quarter")
    assert r.is_implicit()
    mat = Material()
    for phi in (0.6, 0.8, 0.8165, 0.83, 0.85):
        for div, S in ((-1.0, 0.5), (-0.01, 1 / 60), (0.0, 0.3), (0.2, 0.05), (3.0, 0.1)):
            p, c = r.invariant_stress(np.array([phi]), np.array([div]), np.array([S]))
            psi = max((PHI_C - phi) / A, 0.0)
            M = float(mat.mu(np.array(psi))) if psi > 0 else 0.248
            k = 2 * div / (M * S)
            with mpmath.workdps(40):
                roots = mpmath.polyroots([1, k, 0, -1], maxsteps=200, extraprec=200)
                x = [z.real for z in roots if abs(z.imag) < 1e-30 and z.real > 0]
            assert len(x) == 1
            assert p[0] == pytest.approx(float(x[0] ** 4) * steady_P(phi, 2 * S), rel=1e-13)


def test_quarter_law_steady_state_is_7_2_with_mu_of_psi():
    r = get_rheology("icidr-blended-quarter")
    gdot = 1 / 30
    phi = np.array([0.70, 0.78, 0.81, 0.8165, 0.817, 0.83, 0.85])
    p, c = r.invariant_stress(phi, 0 * phi, np.full_like(phi, gdot / 2))
    np.testing.assert_allclose(p, [steady_P(f, gdot) for f in phi], rtol=1e-13)
    psi = np.maximum((PHI_C - phi) / A, 0)
    np.testing.assert_allclose(c * (gdot / 2) / p, Material().mu(psi), rtol=1e-12)


@pytest.mark.slow  # a whole symbolic report of the quarter law: ~30 s
def test_quarter_law_conditions_hold_but_Y_is_negative_under_strong_compaction():
    """(4.3)-(4.5) proved by sympy; Y < 0 for p >> P, and every state of the grid where the symbol
    (1-D or 2-D) is not negative has c = Y/||S|| < 0."""
    report = wb.law_report("icidr-blended-quarter", with_curves=False)
    assert all(c["status"] == "holds" and c["method"] == "symbolic" for c in report["conditions"].values())
    pos = report["positivity"]
    assert pos["status"] == "fails" and pos["counterexample"]["value"] < 0
    r = get_rheology("icidr-blended-quarter")
    ce = pos["counterexample"]
    steady = steady_P(ce["phi"], ce["I"] * np.sqrt(ce["p"]))
    assert ce["p"] > 10 * steady                                                # strong compaction
    st = report["stability"]
    assert st["two_d"]["well_posed"] is False
    grid = wb._grid_states(r)
    bad = np.array(st["two_d"]["Lambda_max"]) >= 0
    bad_1d = np.array(st["one_d"]["Lambda_plus"]) >= 0
    assert np.all(bad[bad_1d])                                    # 1-D ill-posed states are 2-D ill-posed
    F, G, R = (x[bad] for x in grid)
    _, c = r.kernels(INVARIANTS).stress_numpy(F, R * G / 2, G / 2, r.material.params)
    assert bad.any() and np.all(c < 0)
    assert any("Y < 0" in note for note in st["notes"])
    assert report["well_posed"] is False


def test_sample_is_dense_across_phi_c():
    """The condition sample and (for laws beyond phi_c) the symbol grid have phi between 0.794 and 0.827."""
    r = get_rheology("icidr-blended")
    _, _, F, text = wb.condition_sample(r)
    phis = np.unique(F)
    gap = phis[(phis > 0.785) & (phis < 0.832)]
    assert gap.size >= 25 and np.max(np.diff(gap)) < 2e-3 and "around phi_c" in text
    g = np.unique(wb._grid_states(r)[0])
    assert np.sum((g > 0.794) & (g < 0.827)) >= 7


def test_half_power_blended_law_fails_4_4_and_positivity_only_under_compaction():
    c = wb.check_conditions(get_rheology("icidr-blended-half"))
    region = c["(4.4)"].region
    assert c["(4.4)"].status == "fails" and region["p"][0] >= 1e2
    pos = wb.check_positivity(get_rheology("icidr-blended-half"))
    assert pos.status == "fails" and pos.region["p"][0] >= 1.0


@pytest.mark.parametrize("phi0", [0.8165, 0.83])
def test_quarter_law_runs_up_to_and_across_phi_c(phi0):
    from icidr_pde import run

    res = run("icidr-blended-quarter", "shear", N=33, t_end=1.0, times=[0, 1], phi0=phi0, method="BDF",
              rtol=1e-6, atol=1e-9)
    assert not res.blew_up, res.reason
    assert abs(res.mass_drift) < 1e-10
    w = res.max_w_at_times()
    assert w["1"] < 1e-3 * w["0"]
