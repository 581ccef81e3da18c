"""2-D plane-wave numbers (stability.directional) against the 1-D toolkit and closed forms."""

import math

import numpy as np
import pytest

from stability import directional as D
from stability.material import TABLE1
from stability.mui import M_numeric
from stability.numeric import stability_numbers

STEADY = (0.0, 1.0 / 30.0, 0.0, 0.0)          # steady shear u = z/30: grad u = [[0, 1/30], [0, 0]]
ONE_D_STATES = [(0.78, 1 / 30, 0.05), (0.78, 1 / 30, 0.0), (0.7, 0.3, -0.1), (0.6, -0.2, 0.4), (0.8, 0.0, -0.3)]


def _psi(phi):
    return (TABLE1["phi_c"] - phi) / TABLE1["a"]          # (2.13)


def _random_states(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        yield float(rng.uniform(0.5, 0.81)), tuple(rng.normal(size=4) * 10 ** rng.uniform(-3, 1))


@pytest.mark.parametrize("name", ["mui", "icidr"])
@pytest.mark.parametrize("state", ONE_D_STATES)
def test_theta_90_reproduces_1d_numbers(name, state):
    phi, uz, wz = state
    r = D.directional_stability(name, phi, (0.0, uz, 0.0, wz))
    sn = stability_numbers(name, phi, uz, wz).to_json()
    at = r.to_json()["at_90_deg"]
    for k in ("trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "lambda0_limit"):
        assert at[k] == pytest.approx(sn[k], rel=1e-12, abs=1e-13 * abs(sn["trace_gamma"])), k
    assert at["max_re_eig_over_xi2"] == pytest.approx(sn["max_re_eig_over_xi2"], rel=1e-8, abs=1e-12)
    i90 = int(np.flatnonzero(r.angles_deg == 90.0)[0])
    assert r.lambda_max[i90] == pytest.approx(sn["lambda_plus"], rel=1e-12)


def _mui_closed_form(phi, L, angles_deg):
    """eig(-Gamma) of mu(I) from the closed form (4 s/(phi Psi^2)) {cos 2(theta - beta) - M, -M/2}."""
    ux, uz, wx, wz = L
    s = 0.5 * math.hypot(ux - wz, uz + wx)
    beta = 0.5 * math.degrees(math.atan2(uz + wx, ux - wz))
    M = float(M_numeric(phi))
    pref = 4 * s / (phi * _psi(phi) ** 2)
    lam = pref * np.maximum(np.cos(2 * np.deg2rad(np.asarray(angles_deg) - beta)) - M, -M / 2)
    half = 0.5 * math.degrees(math.acos(M))
    return lam, beta % 180.0, half, pref * (1 - M)


def test_mui_steady_shear_has_ill_posed_interval():
    """Issue 11: mu(I) at steady shear (phi0 = 0.78, u_z = 1/30) is ill-posed for 45 deg +- arccos(M)/2."""
    r = D.directional_stability("mui", 0.78, STEADY)
    _, beta, half, top = _mui_closed_form(0.78, STEADY, [0.0])
    assert beta == pytest.approx(45.0)
    assert len(r.ill_posed_intervals_deg) == 1
    a, b = r.ill_posed_intervals_deg[0]
    assert a == pytest.approx(45.0 - half, abs=1e-8) and b == pytest.approx(45.0 + half, abs=1e-8)
    assert r.worst_angle_deg == pytest.approx(45.0, abs=1e-5)
    assert r.max_lambda == pytest.approx(top, rel=1e-10)
    assert not r.well_posed
    # while the 1-D direction (theta = 90 deg) is well-posed: the shear cell hides it (chi < 0)
    assert r.at_90_deg["lambda_plus"].real < 0 and stability_numbers("mui", 0.78, 1 / 30, 0.0).chi < 0


@pytest.mark.parametrize("phi, L", list(_random_states(25, seed=11)))
def test_mui_matches_closed_form_at_random_states(phi, L):
    r = D.directional_stability("mui", phi, L)
    lam, beta, half, top = _mui_closed_form(phi, L, r.angles_deg)
    np.testing.assert_allclose(r.lambda_max, lam, rtol=1e-10, atol=1e-12 * np.abs(lam).max())
    assert r.max_lambda == pytest.approx(top, rel=1e-9)
    d = abs((r.worst_angle_deg - beta + 90.0) % 180.0 - 90.0)
    assert d < 1e-4
    # one ill-posed interval of width arccos(M) centred on beta (split in two if it contains 0 = 180 deg)
    width = sum(b - a for a, b in r.ill_posed_intervals_deg)
    assert width == pytest.approx(2 * half, abs=1e-7)
    for a, b in r.ill_posed_intervals_deg:
        assert 0.0 <= a < b <= 180.0
        mid = 0.5 * (a + b)
        assert np.cos(2 * np.deg2rad(mid - beta)) > float(M_numeric(phi))


def test_icidr_closed_form_and_no_ill_posed_direction():
    """iCIDR: lambda_max(theta) = -2 (R - div u)/(phi Psi^2) at every angle, < 0, at every sampled state."""
    states = list(_random_states(60, seed=5))
    states += [(0.78, (-0.1, 0.0, 0.0, -0.1)), (0.7, (-0.2, 0.3, -0.3, -0.2)), (0.79, STEADY),
               (0.78, (0.0, 1 / 30, 0.0, 0.05)), (0.6, (1.0, 0.0, 0.0, 0.9))]
    for phi, L in states:
        r = D.directional_stability("icidr", phi, L)
        ux, uz, wx, wz = L
        div, s = ux + wz, 0.5 * math.hypot(ux - wz, uz + wx)
        M = float(M_numeric(phi))
        R = math.hypot(div, M * s)
        q = (M * s) ** 2 / (R + div) if div > 0 else R - div        # R - div without cancellation
        target = -2 * q / (phi * _psi(phi) ** 2)
        np.testing.assert_allclose(r.lambda_max, target, rtol=1e-9)
        assert r.ill_posed_intervals_deg == [] and r.well_posed and r.max_lambda < 0


def test_icidr_degenerate_state_is_refused():
    """||S|| = 0 and div u > 0: p = 0 (4.13), Gamma = 0 -- a clear error, not a verdict."""
    with pytest.raises(ValueError, match="velocity_gradient"):
        D.directional_stability("icidr", 0.7, (0.1, 0.2, -0.2, 0.1))


def test_mui_not_differentiable_at_zero_shear():
    with pytest.raises(ValueError, match="velocity_gradient.*not differentiable"):
        D.directional_stability("mui", 0.7, (-0.1, 0.0, 0.0, -0.1))


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_rotation_covariance(name):
    """Gamma(Q n; Q L Q^T) = Q Gamma(n; L) Q^T: the law is isotropic."""
    L = np.array([[0.03, 0.2], [-0.05, 0.07]])
    rot = 37.0
    c, s = math.cos(math.radians(rot)), math.sin(math.radians(rot))
    Q = np.array([[c, -s], [s, c]])
    angles = np.arange(0.0, 180.0, 7.0)
    a, B = D.principal_part(name, 0.75, L.ravel())
    aq, Bq = D.principal_part(name, 0.75, (Q @ L @ Q.T).ravel())
    G, al = D.gamma_alpha(a, B, angles)
    Gq, alq = D.gamma_alpha(aq, Bq, angles + rot)
    np.testing.assert_allclose(Gq, Q @ G @ Q.T, rtol=1e-10, atol=1e-12 * np.abs(G).max())
    np.testing.assert_allclose(alq, al @ Q.T, rtol=1e-10, atol=1e-12 * np.abs(al).max())


def test_user_law_object_and_callable():
    """Any law with symbolic_stress(phi, div_u, norm_S): a compressible Newtonian fluid (Navier-Stokes symbol)."""
    import sympy as sp
    from stability.symbols import MATERIAL_SYMBOLS

    class Newtonian:
        name = "newtonian"

        def symbolic_stress(self, phi, div_u, norm_S):
            return (phi / (MATERIAL_SYMBOLS["phi_c"] - phi) - sp.Rational(3, 10) * div_u, sp.Rational(1, 5))

    r = D.directional_stability(Newtonian(), 0.6, STEADY)
    # Gamma = (eta I + zeta n n^T)/phi with eta = c/2 = 0.1, zeta = 0.3: Lambda_max = -eta/phi at every angle
    np.testing.assert_allclose(r.lambda_max, -0.1 / 0.6, rtol=1e-13)
    np.testing.assert_allclose(r.lambda_minus.real, -0.4 / 0.6, rtol=1e-13)
    assert r.rheology == "newtonian" and r.well_posed
    # a law as a plain callable; an unknown symbol is named in the error
    r2 = D.directional_stability(lambda phi, div_u, norm_S: (norm_S**2, 1 + norm_S), 0.6, STEADY)
    assert r2.lambda_max.shape == (180,)
    k = sp.Symbol("k")
    with pytest.raises(ValueError, match="k"):
        D.directional_stability(lambda phi, div_u, norm_S: (k * norm_S**2, norm_S), 0.6, STEADY)


def test_wrapping_interval_is_split_and_partial_ranges():
    """An ill-posed set through 0 = 180 deg is reported as [0, b] and [a, 180]; partial ranges are clipped."""
    L = (0.1, 0.0, 0.0, -0.1)             # pure strain, stretching along x: beta = 0
    r = D.directional_stability("mui", 0.78, L)
    _, beta, half, _ = _mui_closed_form(0.78, L, [0.0])
    assert beta == pytest.approx(0.0)
    (a0, b0), (a1, b1) = r.ill_posed_intervals_deg
    assert a0 == 0.0 and b0 == pytest.approx(half, abs=1e-8)
    assert a1 == pytest.approx(180.0 - half, abs=1e-8) and b1 == 180.0
    part = D.directional_stability("mui", 0.78, STEADY, angles_deg=D.parse_angles("30:60:1"))
    assert part.ill_posed_intervals_deg == [[30.0, 60.0]]
    # a step that does not divide 180 still closes the circle: the interval through 0 = 180 deg is found
    odd = D.directional_stability("mui", 0.78, L, angles_deg=D.parse_angles("0:180:7"))
    assert odd.ill_posed_intervals_deg[0] == [0.0, pytest.approx(half, abs=1e-8)]
    assert odd.ill_posed_intervals_deg[1] == [pytest.approx(180.0 - half, abs=1e-8), 180.0]


def test_parse_angles():
    np.testing.assert_array_equal(D.parse_angles("0:180:1"), np.arange(180.0))
    np.testing.assert_array_equal(D.parse_angles("30:60:15"), [30.0, 45.0, 60.0])
    np.testing.assert_array_equal(D.parse_angles("-90:90:45"), [-90.0, -45.0, 0.0, 45.0])
    for bad in ("0:180", "a:b:c", "0:180:0", "10:0:1", "0:inf:1"):
        with pytest.raises(ValueError, match="angles"):
            D.parse_angles(bad)


def test_bad_input_names_parameter():
    with pytest.raises(ValueError, match="phi"):
        D.directional_stability("mui", 0.9, STEADY)
    with pytest.raises(ValueError, match="velocity_gradient"):
        D.directional_stability("mui", 0.7, (0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="velocity_gradient"):
        D.directional_stability("mui", 0.7, (0.0, float("nan"), 0.0, 0.0))
    with pytest.raises(ValueError, match="rheology"):
        D.directional_stability("newtonian", 0.7, STEADY)


def test_polar_plot(tmp_path):
    rs = [D.directional_stability(n, 0.78, STEADY) for n in ("mui", "icidr")]
    path = D.save_polar(rs, str(tmp_path / "p.png"), title="steady shear")
    assert (tmp_path / "p.png").stat().st_size > 10000
    assert [p.name for p in tmp_path.iterdir()] == ["p.png"]
    assert D.one_d_lambda_plus(rs[0]) == pytest.approx(stability_numbers("mui", 0.78, 1 / 30, 0).lambda_plus.real)
    assert path.endswith("p.png")


def test_scan_random_states():
    """Sampled verdicts: iCIDR well-posed at every state, mu(I) ill-posed at every (shearing) state."""
    states = D.random_states(40, seed=3)
    ic = D.scan("icidr", states)
    assert ic["n_states"] == 40 and ic["n_ill_posed"] == 0 and ic["max_lambda"] < 0
    mu = D.scan("mui", states, angles_deg=D.parse_angles("0:180:2"))
    assert mu["n_ill_posed"] == 40 and mu["worst"]["lambda_max"] == mu["max_lambda"] > 0


def test_lambda_max_field_matches_pointwise_analysis():
    """On fields (the 2-D simulator's view): the same max over angles as directional_stability, nan where undefined."""
    rng = np.random.default_rng(8)
    grad = rng.normal(size=(2, 2, 3, 4)) * 0.1
    phi = rng.uniform(0.6, 0.8, size=(3, 4))
    grad[:, :, 0, 0] = [[-0.1, 0.0], [0.0, -0.1]]            # ||S|| = 0, div u < 0
    for name in ("mui", "icidr"):
        lam, worst = D.lambda_max_field(name, phi, grad)
        assert lam.shape == worst.shape == (3, 4)
        for idx in [(0, 1), (1, 2), (2, 3)]:
            r = D.directional_stability(name, phi[idx], grad[:, :, idx[0], idx[1]].ravel())
            assert lam[idx] == pytest.approx(float(r.lambda_max.max()), rel=1e-12)
        if name == "mui":
            assert np.isnan(lam[0, 0]) and np.all(lam[~np.isnan(lam)] > 0)
        else:
            assert np.all(lam < 0)
    with pytest.raises(ValueError, match="grad_u"):
        D.lambda_max_field("mui", phi, grad[0])


def test_law_defined_through_the_registry():
    """A law built with icidr_pde.rheology.define_rheology (here mu(I)'s p and c retyped) gives mu(I)'s numbers."""
    from icidr_pde.rheology import define_rheology
    from icidr_pde.rheology import symbols as s

    cls = define_rheology("mui_copy_for_test", (2 * s.norm_S / s.Psi) ** 2, 4 * s.M * s.norm_S / s.Psi**2,
                          register=False)
    r = D.directional_stability(cls(), 0.78, STEADY)
    ref = D.directional_stability("mui", 0.78, STEADY)
    np.testing.assert_allclose(r.lambda_max, ref.lambda_max, rtol=1e-13)
    np.testing.assert_allclose(r.ill_posed_intervals_deg, ref.ill_posed_intervals_deg, rtol=1e-12)
