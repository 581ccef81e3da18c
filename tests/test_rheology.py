"""Rheology kernels against independent truth: the one sympy definition (itself checked against
the paper's general laws in tests/stability/test_rheologies.py) evaluated in high precision,
finite differences, identities of the material laws, and limits."""

import mpmath
import numpy as np
import pytest
import sympy as sp
from scipy.optimize._numdiff import approx_derivative

from icidr_pde.rheology import (SHEAR_CELL, Material, SaturatingDilatancy, chi, define_rheology,
                                get_rheology)
from icidr_pde.rheology import symbols as rs

phi, uz, wz = sp.Symbol("phi", positive=True), *SHEAR_CELL.rate_symbols()

MATERIALS = {"table1": Material(), "saturating": Material(dilatancy="saturating")}


def shear_cell_stress(name, mat):
    """(p, tau_xz, tau_zz)(phi, u_z, w_z) from the invariant definition, plain (not stable) form."""
    rheology = get_rheology(name, mat)
    div, norm = SHEAR_CELL.invariants((uz, wz))
    p, c = rheology.symbolic_stress(phi, div, norm)
    return SHEAR_CELL.stresses(p, c, (uz, wz))


def sample_points(mat, n=12, seed=1):
    rng = np.random.default_rng(seed)
    lo, hi = mat.phi_range
    return np.column_stack([rng.uniform(max(lo, 0.70), min(hi, 0.81), n), rng.normal(0, 0.1, n),
                            rng.normal(0, 0.1, n)])


@pytest.mark.parametrize("law", sorted(MATERIALS))
@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_stress_and_jacobian_match_symbolic_definition(name, law):
    """Generated kernels (numpy and numba) against the definition in 30-digit arithmetic."""
    mat = MATERIALS[law]
    rheology = get_rheology(name, mat)
    exprs = shear_cell_stress(name, mat)
    points = sample_points(mat)
    values = np.array(rheology.stress(*points.T))
    jac = np.array(rheology.stress_jacobian(*points.T)).reshape(3, 3, -1)
    kernels = rheology.kernels()
    compiled = np.array(kernels.stress_array(*points.T.copy(), mat.params))
    np.testing.assert_allclose(compiled, values, rtol=1e-13, atol=1e-16)
    compiled_jac = np.array(kernels.stress_jacobian_array(*points.T.copy(), mat.params)).reshape(3, 3, -1)
    np.testing.assert_allclose(compiled_jac, jac, rtol=1e-12, atol=1e-14)
    for k, expr in enumerate(exprs):
        f = sp.lambdify((phi, uz, wz), expr, "mpmath")
        grads = [sp.lambdify((phi, uz, wz), sp.diff(expr, v), "mpmath") for v in (phi, uz, wz)]
        for i, pt in enumerate(points):
            args = [mpmath.mpf(float(x)) for x in pt]
            exact = float(f(*args))
            assert values[k, i] == pytest.approx(exact, rel=1e-12, abs=1e-15)
            for j in range(3):
                assert jac[k, j, i] == pytest.approx(float(grads[j](*args)), rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("law", sorted(MATERIALS))
@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_generated_jacobian_matches_finite_differences(name, law):
    mat = MATERIALS[law]
    rheology = get_rheology(name, mat)
    for pt in sample_points(mat, n=6, seed=7):
        J = np.array(rheology.stress_jacobian(*pt)).reshape(3, 3)
        J_fd = approx_derivative(lambda x: np.array(rheology.stress(*x), float), pt, method="3-point")
        np.testing.assert_allclose(J, J_fd, rtol=1e-6, atol=1e-9 * np.abs(J_fd).max())


def test_icidr_equals_mui_without_dilation():
    """With w_z = 0 (isochoric), iCIDR recovers mu(I),Phi(I): same p and tau (§4)."""
    rng = np.random.default_rng(2)
    phi_v, uz_v = rng.uniform(0.7, 0.81, 50), rng.normal(0, 1, 50)
    a = get_rheology("mui").stress(phi_v, uz_v, 0.0)
    b = get_rheology("icidr").stress(phi_v, uz_v, 0.0)
    for x, y in zip(a, b):
        np.testing.assert_allclose(x, y, rtol=1e-13, atol=1e-300)


def test_icidr_pressure_free_of_cancellation():
    """For w_z >> u_z > 0 the root difference cancels; compare with 50-digit arithmetic."""
    mat = Material()
    exprs = shear_cell_stress("icidr", mat)
    f = sp.lambdify((phi, uz, wz), exprs[0], "mpmath")
    r = get_rheology("icidr", mat)
    mpmath.mp.dps = 50
    try:
        for u_val, w_val in [(1e-6, 1.0), (1e-9, 0.3), (3e-4, 2.0)]:
            exact = float(f(mpmath.mpf(0.78), mpmath.mpf(u_val), mpmath.mpf(w_val)))
            assert r.stress(0.78, u_val, w_val)[0] == pytest.approx(exact, rel=1e-13)
            compiled = r.kernels().stress(0.78, u_val, w_val, mat.params)[0]
            assert compiled == pytest.approx(exact, rel=1e-13)
    finally:
        mpmath.mp.dps = 15


def test_icidr_zero_pressure_set():
    """(4.13): p = 0 exactly when ||S|| = 0 and div u >= 0; p > 0 otherwise."""
    r = get_rheology("icidr")
    p, txz, tzz = r.stress([0.78, 0.78, 0.78], [0.0, 0.0, 1e-3], [0.0, -1e-3, 1e-3])
    assert p[0] == 0.0 and txz[0] == 0.0 and tzz[0] == 0.0
    assert p[1] > 0 and p[2] > 0
    p, c = r.invariant_stress([0.78] * 3, [0.5, 0.0, -0.5], [0.0, 0.0, 0.0])
    assert p[0] == 0 and p[1] == 0 and p[2] > 0 and np.all(c[:2] == 0)


def test_symbolic_stress_interface():
    """symbolic_stress: numbers by default, material symbols with symbolic=True; tau = c S."""
    r = get_rheology("icidr")
    p, c = r.symbolic_stress(rs.phi, rs.div_u, rs.norm_S)
    assert p.free_symbols == {rs.phi, rs.div_u, rs.norm_S}
    p_sym, _ = r.symbolic_stress(rs.phi, rs.div_u, rs.norm_S, symbolic=True)
    assert {rs.MATERIAL_SYMBOLS[k] for k in ("mu_s", "mu_d", "I0", "phi_c", "a")} <= p_sym.free_symbols
    values = {rs.phi: sp.Rational(78, 100), rs.div_u: sp.Rational(1, 20), rs.norm_S: sp.Rational(1, 30)}
    prm = {rs.MATERIAL_SYMBOLS[k]: v for k, v in r.material.values().items()}
    assert sp.N(p.subs(values) - p_sym.subs(values).subs(prm), 30) == 0
    numeric = r.invariant_stress(0.78, 0.05, 1 / 30)
    assert float(numeric[0]) == pytest.approx(float(p.subs(values)), rel=1e-13)
    assert float(numeric[1]) == pytest.approx(float(c.subs(values)), rel=1e-13)


def test_rheology_defined_at_run_time():
    """define_rheology: iCIDR's law typed as expressions gives iCIDR's kernels; registered by name."""
    from icidr_pde.rheology import RHEOLOGIES

    R = sp.sqrt(rs.div_u**2 + rs.M**2 * rs.norm_S**2)
    cls = define_rheology("icidr_copy_for_test", (2 * (R - rs.div_u) / (rs.M * rs.Psi)) ** 2,
                          4 * (R - rs.div_u) / rs.Psi**2, register=True)
    try:
        mine, ref = get_rheology("icidr_copy_for_test"), get_rheology("icidr")
        assert isinstance(mine, cls)
        pts = sample_points(Material(), n=20, seed=3)
        pts[:, 2] = -np.abs(pts[:, 2])  # w_z <= 0: the plain form has no cancellation there
        np.testing.assert_allclose(np.array(mine.stress(*pts.T)), np.array(ref.stress(*pts.T)), rtol=1e-12)
        np.testing.assert_allclose(np.array(mine.stress_jacobian(*pts.T)),
                                   np.array(ref.stress_jacobian(*pts.T)), rtol=1e-10, atol=1e-14)
    finally:
        RHEOLOGIES.pop("icidr_copy_for_test")


def test_material_functions():
    m = Material()
    assert (m.mu_s, m.mu_d, m.I0, m.phi_c, m.a) == (0.248, 0.588, 0.145, 0.817, 0.314)  # Table 1
    assert m.mu(0.0) == pytest.approx(m.mu_s)
    assert m.mu(1e12) == pytest.approx(m.mu_d)
    assert m.mu(m.I0) == pytest.approx((m.mu_s + m.mu_d) / 2)
    I = np.linspace(0.01, 0.5, 7)
    np.testing.assert_allclose(m.Psi(m.Phi(I)), I)  # (2.13) inverts (2.11)
    assert Material(**m.to_dict()) == m


@pytest.mark.parametrize("law", sorted(MATERIALS))
def test_psi_inverts_phi_symbolically(law):
    mat = MATERIALS[law]
    I = rs.I
    assert sp.simplify(mat.symbolic_Psi(mat.symbolic_Phi(I, True), True) - I) == 0


def test_saturating_dilatancy_law():
    """Section 2's law stays above phi_min, is tangent to (2.11) at I = 0 with the defaults, and
    its inertial range is (phi_min, phi_c)."""
    mat = MATERIALS["saturating"]
    law = mat.dilatancy
    assert isinstance(law, SaturatingDilatancy)
    I = rs.I
    Phi = mat.symbolic_Phi(I)
    assert sp.limit(Phi, I, sp.oo) == sp.Rational(repr(law.phi_min))
    slope = sp.limit(sp.diff(Phi, I), I, 0)
    assert float(slope) == pytest.approx(-Material().a)  # tangent to (2.11)
    assert mat.phi_range == (law.phi_min, law.phi_c)
    assert np.all(np.diff(mat.Phi(np.geomspace(1e-3, 1e6, 50))) < 0) and mat.Phi(1e6) > law.phi_min
    with pytest.raises(ValueError, match=r"`phi` must lie in \(phi_min, phi_c\)"):
        mat.check_phi(0.5)
    with pytest.raises(ValueError, match="phi_min"):
        Material(dilatancy="saturating", phi_min=0.9)
    with pytest.raises(ValueError, match="I_star"):
        Material(dilatancy="saturating", I_star=0.0)
    with pytest.raises(ValueError, match=r"unknown Material parameter.*\ba\b"):
        Material(dilatancy="saturating", a=0.3)


def test_saturating_law_stability_numbers_from_the_toolkit():
    """mu(I) with the saturating law: the toolkit's Lambda_pm equal the closed-form roots of (A9) for
    mu(I), -M s/(phi Psi^2) and 2 (w_z - M s)/(phi Psi^2), evaluated with this law's M and Psi; iCIDR
    stays well-posed (the proof holds for any positive M, Psi)."""
    from stability.numeric import stability_numbers

    mat = MATERIALS["saturating"]
    ph, u, w = 0.78, 1 / 30, 0.05
    sn = stability_numbers("mui", ph, u, w, material=mat)
    M, Psi = float(mat.M(ph)), float(mat.Psi(ph))
    s = np.hypot(u, w)
    roots = sorted([-M * s / (ph * Psi**2), 2 * (w - M * s) / (ph * Psi**2)], reverse=True)
    assert sn.lambda_plus.real == pytest.approx(roots[0], rel=1e-10)
    assert sn.lambda_minus.real == pytest.approx(roots[1], rel=1e-10)
    assert sn.lambda_plus.real > 0 and sn.chi > 0  # still ill-posed at the state of fig 2
    assert sn.M == pytest.approx(M)
    rng = np.random.default_rng(8)
    for _ in range(10):
        sn = stability_numbers("icidr", rng.uniform(0.6, 0.81), *rng.normal(size=2), material=mat)
        assert sn.trace_gamma > 0 and sn.det_gamma > 0 and sn.lambda_plus.real < 0


@pytest.mark.parametrize("kwargs, name", [
    ({"mu_d": 0.2}, "mu_s"), ({"mu_d": 1.2}, "mu_d"), ({"a": 0.0}, "`a`"), ({"I0": -1.0}, "I0"),
    ({"phi_c": 1.5}, "phi_c"), ({"mu_s": float("nan")}, "mu_s"), ({"dilatancy": "cubic"}, "dilatancy"),
])
def test_material_validation_names_parameter(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Material(**kwargs)


def test_phi_range_and_rheology_name_errors():
    with pytest.raises(ValueError, match=r"phi.*\(0, phi_c\)"):
        Material().check_phi([0.5, 0.82])
    with pytest.raises(ValueError, match="rheology"):
        get_rheology("bingham")
    for bad_phi in (0.817, 0.9, -0.1, float("nan")):
        with pytest.raises(ValueError, match=r"`phi` must lie in \(0, phi_c\)"):
            get_rheology("icidr").stress(bad_phi, 0.1, 0.0)
    with pytest.raises(ValueError, match="`wz`"):
        get_rheology("mui").stress(0.78, 0.1, float("inf"))


def test_chi_sign():
    """chi (A18) > 0 where w_z/|u_z| exceeds M/sqrt(1-M^2), i.e. where (A16) holds."""
    r = get_rheology("mui")
    M = r.material.M(0.78)
    crit = M / np.sqrt(1 - M**2)
    values = r.chi(0.78, [1.0, 1.0, 0.0, 0.0, 0.0], [crit * 1.01, crit * 0.99, 0.1, -0.1, 0.0])
    assert values[0] > 0 > values[1] and values[2] == np.inf and values[3] == -np.inf
    assert np.isnan(values[4])  # u_z = w_z = 0: Gamma = 0, neither (A16) nor (A17)
    # chi > 0 <=> w_z / sqrt(u_z^2 + w_z^2) > M, (A16)
    uz_v, wz_v = 1.0, crit * 1.01
    assert wz_v / np.hypot(uz_v, wz_v) > M
    np.testing.assert_array_equal(chi(0.78, [1.0], [0.1]), r.chi(0.78, [1.0], [0.1]))
