"""Rheology kernels against independent truth: sympy derivations from the paper's
general laws (3.6)/(3.8) and (4.12)/(4.14), high-precision arithmetic, and limits."""

import mpmath
import numpy as np
import pytest
import sympy as sp

from icidr_pde.rheology import Material, get_rheology

phi, uz, wz = sp.symbols("phi u_z w_z", real=True)


def symbolic_stress(name, mat):
    """p, tau_xz, tau_zz derived here from the general 2-D laws, not from (5.1)/(5.6)."""
    mu_s, mu_d, I0, phi_c, a = (sp.Rational(str(v)) for v in mat.params)
    psi = (phi_c - phi) / a  # (2.13)
    M = mu_s + (mu_d - mu_s) / (I0 / psi + 1)  # (2.10) at I = Psi
    S = sp.Matrix([[-wz / 2, uz / 2], [uz / 2, wz / 2]])  # (3.4)
    normS = sp.sqrt((S * S).trace() / 2)  # ||T|| = sqrt(tr(T^2)/2)
    div = wz
    if name == "mui":
        p = (2 * normS / psi) ** 2  # (2.14), d = rho = 1
        tau = M * p * S / normS  # (2.6)-(2.7)
    else:
        p = (2 / (M * psi)) ** 2 * (sp.sqrt(div**2 + M**2 * normS**2) - div) ** 2  # (4.12)
        tau = 2 * M / psi * sp.sqrt(p) * S  # (4.14)
    return p, tau[0, 1], tau[1, 1]


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_stress_and_jacobian_match_symbolic_derivation(name):
    mat = Material()
    rheology = get_rheology(name, mat)
    exprs = symbolic_stress(name, mat)
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(0.70, 0.81, 12), rng.normal(0, 0.1, 12), rng.normal(0, 0.1, 12)])
    values = np.array(rheology.stress(*points.T))
    jac = np.array(rheology.stress_jacobian(*points.T)).reshape(3, 3, -1)
    for k, expr in enumerate(exprs):
        f = sp.lambdify((phi, uz, wz), expr, "mpmath")
        grads = [sp.lambdify((phi, uz, wz), sp.diff(expr, v), "mpmath") for v in (phi, uz, wz)]
        for i, pt in enumerate(points):
            args = [mpmath.mpf(float(x)) for x in pt]
            exact = float(f(*args))
            assert values[k, i] == pytest.approx(exact, rel=1e-12, abs=1e-15)
            for j in range(3):
                assert jac[k, j, i] == pytest.approx(float(grads[j](*args)), rel=1e-9, abs=1e-12)


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
    exprs = symbolic_stress("icidr", mat)
    f = sp.lambdify((phi, uz, wz), exprs[0], "mpmath")
    mpmath.mp.dps = 50
    try:
        for u_val, w_val in [(1e-6, 1.0), (1e-9, 0.3), (3e-4, 2.0)]:
            exact = float(f(mpmath.mpf(0.78), mpmath.mpf(u_val), mpmath.mpf(w_val)))
            value = get_rheology("icidr", mat).stress(0.78, u_val, w_val)[0]
            assert value == pytest.approx(exact, rel=1e-13)
    finally:
        mpmath.mp.dps = 15


def test_icidr_zero_pressure_set():
    """(4.13): p = 0 exactly when ||S|| = 0 and div u >= 0; p > 0 otherwise."""
    r = get_rheology("icidr")
    p, txz, tzz = r.stress([0.78, 0.78, 0.78], [0.0, 0.0, 1e-3], [0.0, -1e-3, 1e-3])
    assert p[0] == 0.0 and txz[0] == 0.0 and tzz[0] == 0.0
    assert p[1] > 0 and p[2] > 0


def test_material_functions():
    m = Material()
    assert (m.mu_s, m.mu_d, m.I0, m.phi_c, m.a) == (0.248, 0.588, 0.145, 0.817, 0.314)  # Table 1
    assert m.mu(0.0) == pytest.approx(m.mu_s)
    assert m.mu(1e12) == pytest.approx(m.mu_d)
    assert m.mu(m.I0) == pytest.approx((m.mu_s + m.mu_d) / 2)
    I = np.linspace(0.01, 0.5, 7)
    np.testing.assert_allclose(m.Psi(m.Phi(I)), I)  # (2.13) inverts (2.11)


@pytest.mark.parametrize("kwargs, name", [
    ({"mu_d": 0.2}, "mu_s"), ({"mu_d": 1.2}, "mu_d"), ({"a": 0.0}, "`a`"), ({"I0": -1.0}, "I0"),
    ({"phi_c": 1.5}, "phi_c"), ({"mu_s": float("nan")}, "mu_s"),
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
    chi = r.chi(0.78, [1.0, 1.0, 0.0], [crit * 1.01, crit * 0.99, 0.1])
    assert chi[0] > 0 > chi[1] and np.isinf(chi[2])
    # chi > 0 <=> w_z / sqrt(u_z^2 + w_z^2) > M, (A16)
    uz_v, wz_v = 1.0, crit * 1.01
    assert wz_v / np.hypot(uz_v, wz_v) > M
