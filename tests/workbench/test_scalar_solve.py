"""The scalar solve of the flow rule (laws without a closed-form pressure) against independent truth:
iCIDR forced through it reproduces its closed form (4.12); a law without a closed form agrees with
a 40-digit mpmath root; failures are errors naming the state, never NaN."""

import mpmath
import numpy as np
import pytest
import sympy as sp

from icidr_pde.rheology import INVARIANTS, LawError, define_cidr_law, get_rheology
from icidr_pde.rheology import symbols as s
from icidr_pde.rheology.implicit import FlowRuleError, ImplicitRoot

P = sp.Symbol("p", positive=True)
RNG = np.random.default_rng(7)
TABLE1 = dict(mu_s=0.248, mu_d=0.588, I0=0.145, phi_c=0.817, a=0.314)


@pytest.fixture(scope="module")
def scalar_icidr():
    """iCIDR's (4.7)-(4.8), with the equation of state by the scalar solve instead of (4.12)."""
    return define_cidr_law("icidr-scalar-test", s.M * s.I / s.Psi * P, s.M / 4 * (s.I / s.Psi - s.Psi / s.I),
                           equation_of_state="scalar")()


@pytest.fixture(scope="module")
def log_law():
    """iCIDR plus -log(1 + p)/10 in f: still (4.5) (F increasing in sqrt p), no closed-form root."""
    return define_cidr_law("log-dilatancy-test", s.M * s.I / s.Psi * P,
                           s.M / 4 * (s.I / s.Psi - s.Psi / s.I) - sp.log(1 + P) / 10)()


def states(n=40):
    return RNG.uniform(0.70, 0.81, n), RNG.normal(0, 0.3, n), RNG.normal(0, 0.3, n)


def test_forced_scalar_solve_is_the_symbolic_implicit_root(scalar_icidr, log_law):
    assert scalar_icidr.is_implicit() and log_law.is_implicit()       # sympy finds no root for the log law
    q, c = scalar_icidr._derived()
    assert isinstance(q, ImplicitRoot)
    # sympy's derivative of the root is the implicit function theorem: idiff of the residual
    F = type(q).residual
    qs = type(q).root_symbol
    mat = scalar_icidr.material
    at = {s.phi: sp.Rational(78, 100), s.div_u: sp.Rational(-1, 10), s.norm_S: sp.Rational(1, 5),
          s.M: sp.Rational(3, 10), s.Psi: sp.Rational(1, 10),
          **{mat.values(True)[k]: v for k, v in mat.values(False).items()}}
    for x in (s.div_u, s.norm_S, s.M, s.Psi):
        root = sp.Float(float(q.xreplace(at).evalf(30)), 30)
        mine = sp.diff(q, x).xreplace(at).evalf(30)
        truth = sp.idiff(F, qs, x).xreplace({**at, qs: root}).evalf(30)
        assert float(mine) == pytest.approx(float(truth), rel=1e-12)


def test_forced_scalar_solve_reproduces_the_closed_form_kernels(scalar_icidr):
    """numpy and numba kernels and their Jacobians equal iCIDR's closed-form kernels to round-off."""
    ref = get_rheology("icidr")
    phi, uz, wz = states()
    for a, b in zip(scalar_icidr.stress(phi, uz, wz), ref.stress(phi, uz, wz)):
        np.testing.assert_allclose(a, b, rtol=5e-15, atol=0)
    for a, b in zip(scalar_icidr.stress_jacobian(phi, uz, wz), ref.stress_jacobian(phi, uz, wz)):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14 * np.abs(b).max())
    k, kr, prm = scalar_icidr.kernels(), ref.kernels(), scalar_icidr.material.params
    for a, b in zip(k.stress_array(phi, uz, wz, prm), kr.stress_array(phi, uz, wz, prm)):
        np.testing.assert_allclose(a, b, rtol=5e-15, atol=0)
    for a, b in zip(k.stress_jacobian_array(phi, uz, wz, prm), kr.stress_jacobian_array(phi, uz, wz, prm)):
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=1e-14 * np.abs(b).max())
    # the invariant kernels over the states (4.12) treats specially: zero shear, strong dilation
    phi = np.full(6, 0.78)
    div = np.array([1.0, 10.0, -1.0, 0.5, 0.0, -1e-3])
    S = np.array([1e-7, 1e-7, 0.0, 0.0, 0.0, 1e-9])
    mine = scalar_icidr.invariant_stress(phi, div, S)
    truth = ref.invariant_stress(phi, div, S)
    for a, b in zip(mine, truth):
        np.testing.assert_allclose(a, b, rtol=1e-14, atol=0)
    assert mine[0][3] == 0.0 and mine[0][4] == 0.0                       # (4.13): p = 0 at ||S|| = 0, div u >= 0


def test_forced_scalar_solve_reproduces_the_stability_numbers(scalar_icidr):
    from stability.numeric import stability_numbers

    for state in [(0.78, 1 / 30, 0.05), (0.8, 1.0, -0.4)]:
        a, b = stability_numbers("icidr-scalar-test", *state), stability_numbers("icidr", *state)
        for key in ("trace_gamma", "det_gamma", "lambda_plus", "lambda_minus"):
            assert getattr(a, key) == pytest.approx(getattr(b, key), rel=1e-12, abs=1e-14)


def test_forced_scalar_solve_reproduces_a_run(scalar_icidr):
    """The whole run path (compiled fd kernels, analytic Jacobian): max|w|(t) as iCIDR's, to round-off."""
    from icidr_pde import run

    kw = dict(N=41, t_end=2.0, times=[0, 0.5, 1, 2], method="BDF", rtol=1e-8, atol=1e-11)
    a, b = run("icidr-scalar-test", "shear", **kw), run("icidr", "shear", **kw)
    assert not a.blew_up
    np.testing.assert_allclose(a.max_w_series, b.max_w_series, rtol=1e-9, atol=1e-14)


def _mp_law(phi, div, S, digits=40):
    """sqrt(p) and c of the log law at one state, with mpmath from the law's own formulas (at least
    `digits` digits: mpmath.diff raises the working precision further)."""
    with mpmath.workdps(max(digits, mpmath.mp.dps)):
        phi, div, S = (mpmath.mpf(x) for x in (phi, div, S))
        t = {k: mpmath.mpf(v) for k, v in TABLE1.items()}
        Psi = (t["phi_c"] - phi) / t["a"]
        M = t["mu_s"] + (t["mu_d"] - t["mu_s"]) / (t["I0"] / Psi + 1)

        def f(p, I):  # noqa: E741
            return M / 4 * (I / Psi - Psi / I) - mpmath.log(1 + p) / 10

        def F(q):
            return div - 2 * S * f(q**2, 2 * S / q)

        lo, hi = mpmath.mpf(1), mpmath.mpf(1)      # F increases with q: bracket, then Anderson-Bjorck
        while F(lo) > 0:
            lo /= 2
        while F(hi) < 0:
            hi *= 2
        q = mpmath.findroot(F, (lo, hi), solver="anderson")
        Y = M * (2 * S / q) / Psi * q**2
        return q, Y / S


def test_law_without_closed_form_agrees_with_mpmath(log_law):
    phi, uz, wz = states(12)
    p, txz, tzz = log_law.stress(phi, uz, wz)
    pa = log_law.kernels().stress_array(phi, uz, wz, log_law.material.params)
    for i in range(phi.size):
        S = mpmath.sqrt(mpmath.mpf(uz[i]) ** 2 + mpmath.mpf(wz[i]) ** 2) / 2
        q, c = _mp_law(phi[i], wz[i], S)
        assert p[i] == pytest.approx(float(q**2), rel=4e-15) and pa[0][i] == pytest.approx(float(q**2), rel=4e-15)
        assert txz[i] == pytest.approx(float(c * uz[i] / 2), rel=1e-14)           # S_xz = u_z/2 (3.4)


def test_law_without_closed_form_jacobian_agrees_with_mpmath(log_law):
    """d(p, tau_xz)/d(u_z, w_z) of the kernel against mpmath derivatives of the 40-digit root."""
    phi, uz, wz = 0.78, 0.2, -0.05
    J = np.array(log_law.stress_jacobian(np.array([phi]), np.array([uz]), np.array([wz]))).ravel()

    def p_of(u, w):
        return log_law_p(phi, u, w)

    def txz_of(u, w):
        q, c = _mp_law(phi, w, mpmath.sqrt(u**2 + w**2) / 2, 40)
        return c * u / 2

    with mpmath.workdps(40):
        for k, g in ((0, p_of), (3, txz_of)):
            assert J[k + 1] == pytest.approx(float(mpmath.diff(lambda u: g(u, mpmath.mpf(wz)), mpmath.mpf(uz))),
                                             rel=1e-12)
            assert J[k + 2] == pytest.approx(float(mpmath.diff(lambda w: g(mpmath.mpf(uz), w), mpmath.mpf(wz))),
                                             rel=1e-12)


def log_law_p(phi, u, w):
    q, _ = _mp_law(phi, w, mpmath.sqrt(u**2 + w**2) / 2, 40)
    return q**2


def test_no_positive_root_is_an_error_naming_the_state_never_nan():
    """f = M I/(4 Psi) - 1: 2||S|| f -> -2||S|| as p -> oo, so no p solves the flow rule where div u <= -2||S||."""
    law = define_cidr_law("bounded-dilatancy-test", s.M * s.I / s.Psi * P, s.M * s.I / (4 * s.Psi) - 1,
                          register=False, equation_of_state="scalar")()
    assert law.is_implicit()
    bad = law.admissibility()
    assert bad is not None and bad["div_u"] <= -2 * bad["norm_S"]
    with pytest.raises(LawError, match=r"no positive solution for p, so the law cannot be run .* at phi = "):
        law.check_runnable()
    phi, div, S = np.array([0.78, 0.78]), np.array([-0.1, -1.0]), np.array([0.3, 0.3])
    with pytest.raises(FlowRuleError, match=r"no positive solution for p .* at phi = 0.78, div_u = -1, norm_S = 0.3"):
        law.invariant_stress(phi, div, S)
    k = law.kernels(INVARIANTS)
    assert np.isfinite(k.stress_array(phi[:1], div[:1], S[:1], law.material.params)[0][0])
    with pytest.raises(ValueError, match=r"no positive solution for p .*\(phi, div_u, norm_S\) =.*0.78, -1.0, 0.3"):
        k.stress_array(phi, div, S, law.material.params)


def test_flow_rule_independent_of_p_is_refused():
    cls = define_cidr_law("no-p-dependence-test", s.M * s.I / s.Psi * P, s.M / 4, register=False)
    with pytest.raises(LawError, match=r"does not depend on p"):
        cls()._derived()


def test_equation_of_state_option_is_checked():
    with pytest.raises(ValueError, match=r"`equation_of_state` must be 'auto' or 'scalar'; got 'newton'"):
        define_cidr_law("eos-option-test", s.M * P, s.M, equation_of_state="newton", register=False)
