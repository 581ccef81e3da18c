"""The workbench's laws against independent truth: the paper's formulas, limits, symbolic identities."""

import numpy as np
import pytest
import sympy as sp

from icidr_pde.rheology import (INVARIANTS, SHEAR_CELL, CIDRLaw, LawError, Material, define_cidr_law, define_rheology,
                                define_direct_law, get_rheology)
from icidr_pde.rheology import symbols as s
from icidr_pde.rheology.blended import ALPHA_ITM, K_OVER_D
from icidr_pde.rheology.codegen import generated_source
from icidr_pde.rheology.nonmonotonic import NonMonotonicMu

RNG = np.random.default_rng(12)


def shear_states(n=40, lo=0.70, hi=0.81):
    return RNG.uniform(lo, hi, n), RNG.normal(0, 0.3, n), RNG.normal(0, 0.3, n)


@pytest.fixture(scope="module")
def derived_icidr():
    """iCIDR from (4.7)-(4.8) alone: the workbench solves the flow rule (no closed form given)."""
    cls = define_cidr_law("icidr-derived-test", s.M * s.I / s.Psi * sp.Symbol("p", positive=True),
                          s.M / 4 * (s.I / s.Psi - s.Psi / s.I))
    return cls()


def test_derived_icidr_is_4_12(derived_icidr):
    """The root the workbench picks is (4.12): sqrt(p) = 2 (R - div u)/(M Psi), exactly."""
    q, c = derived_icidr._derived()
    R = sp.sqrt(s.div_u**2 + s.M**2 * s.norm_S**2)
    assert sp.simplify(q - 2 * (R - s.div_u) / (s.M * s.Psi)) == 0
    assert sp.simplify(c - 4 * (R - s.div_u) / s.Psi**2) == 0          # (4.14): c = 2 (M/Psi) sqrt(p)


def test_derived_icidr_reproduces_the_kernels(derived_icidr):
    """Kernels generated from the workbench's derivation equal today's iCIDR kernels to round-off."""
    ref = get_rheology("icidr")
    phi, uz, wz = shear_states()
    for a, b in zip(derived_icidr.stress(phi, uz, wz), ref.stress(phi, uz, wz)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-300)
    for a, b in zip(derived_icidr.stress_jacobian(phi, uz, wz), ref.stress_jacobian(phi, uz, wz)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * np.abs(b).max())
    # the cancellation-free rewriting: div u > 0 with tiny ||S||, where R - div u cancels
    big = np.array([1.0, 10.0]), np.array([1e-7, 1e-7])
    p_d = derived_icidr.invariant_stress(np.array([0.78, 0.78]), *big)[0]
    p_r = ref.invariant_stress(np.array([0.78, 0.78]), *big)[0]
    np.testing.assert_allclose(p_d, p_r, rtol=1e-12)


def test_derived_icidr_reproduces_the_stability_numbers(derived_icidr):
    from stability.numeric import stability_numbers

    for state in [(0.78, 1 / 30, 0.05), (0.8, 1.0, -0.4), (0.72, 0.3, 0.0)]:
        a = stability_numbers("icidr-derived-test", *state)
        b = stability_numbers("icidr", *state)
        for key in ("trace_gamma", "det_gamma", "lambda_plus", "lambda_minus", "lambda0_limit"):
            assert getattr(a, key) == pytest.approx(getattr(b, key), rel=1e-11, abs=1e-14)


def test_mui_through_the_workbench_generates_the_same_kernel_source():
    """mu(I),Phi(I) given as p = (2||S||/Psi)^2, ||tau|| = M p: the generated source is today's, so every
    number (kernels, stability, t*) is identical, not only close."""
    p = (2 * s.norm_S / s.Psi) ** 2
    cls = define_direct_law("mui-direct-test", p, s.M * p)
    # today's law as written before the workbench: (2.14) and c = 4 M ||S||/Psi^2
    today = define_rheology("mui_today_test", p, 4 * s.M * s.norm_S / s.Psi**2, register=False)
    mine, ref = generated_source(cls(), SHEAR_CELL), generated_source(today(), SHEAR_CELL)
    assert body_of(generated_source(get_rheology("mui"), SHEAR_CELL)) == body_of(ref)
    assert body_of(mine) == body_of(ref)


def body_of(text):
    """Generated module text without its first line (which names the rheology)."""
    return text.split("\n", 1)[1]


def test_closed_forms_are_checked_not_trusted():
    class Wrong(CIDRLaw):
        def yield_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
            return M * I / Psi * p

        def dilatancy_function(self, p, I, phi, M, Psi, prm):  # noqa: E741
            return M / 4 * (I / Psi - Psi / I)

        def closed_form(self, phi, div_u, norm_S, M, Psi, prm, stable=False):
            G = sp.sqrt(div_u**2 + M**2 * norm_S**2) + div_u                 # wrong sign
            return (2 * G / (M * Psi)) ** 2, 4 * G / Psi**2

    Wrong.name = "wrong-test"
    with pytest.raises(LawError, match=r"closed_form\(\) p does not solve the flow rule.*phi = "):
        Wrong().verify_closed_form()
    get_rheology("icidr").verify_closed_form()
    get_rheology("icidr-blended-half").verify_closed_form()


def test_flow_rule_without_a_solution_for_p_is_an_error():
    cls = define_cidr_law("no-p-test", s.M * s.I / s.Psi * sp.Symbol("p", positive=True), s.M / 4,
                          register=False)
    with pytest.raises(LawError, match=r"flow rule \(4.2\) with \(2.9\) has no closed-form solution for p"):
        cls()._derived()


def test_law_without_positive_pressure_somewhere_is_not_run():
    from icidr_pde.api import make_pde

    with pytest.raises(LawError, match=r"'mu-psi': the flow rule .* no positive solution for p, so the law cannot "
                                       r"be run .* at phi = .*, div_u = .*, norm_S = "):
        make_pde("mu-psi")


def test_mu_psi_eos_and_its_inadmissible_region():
    """sqrt(p) = (2||S|| - div u/M)/Psi (section 4's Y = M p with (4.3), (4.6)); no positive p where
    div u >= 2 M ||S||."""
    r = get_rheology("mu-psi")
    q, _ = r._derived()
    assert sp.simplify(q - (2 * s.norm_S - s.div_u / s.M) / s.Psi) == 0
    bad = r.admissibility()
    assert bad is not None and bad["div_u"] >= 2 * float(r.material.M(bad["phi"])) * bad["norm_S"]


@pytest.mark.parametrize("name, ref", [("icidr-nonmonotonic", "mui-nonmonotonic"),
                                       ("icidr-saturating-phi", "mui-saturating-phi"), ("icidr", "mui")])
def test_isochoric_limit_recovers_mui(name, ref):
    """At div u = 0 the flow rule gives I = Psi(phi): the law is mu(I),Phi(I) with the same material."""
    a, b = get_rheology(name), get_rheology(ref)
    assert a.material == b.material
    lo, hi = a.material.phi_range
    phi = RNG.uniform(lo + 0.3 * (hi - lo), hi - 1e-3, 30)
    uz = RNG.normal(0, 1, 30)
    for x, y in zip(a.stress(phi, uz, 0 * uz), b.stress(phi, uz, 0 * uz)):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("name", ["icidr", "icidr-nonmonotonic", "icidr-saturating-phi", "mu-psi"])
def test_bagnold_scaling(name):
    """p(lambda grad u) = lambda^2 p and tau(lambda grad u) = lambda^2 tau."""
    r = get_rheology(name)
    lo, hi = r.material.phi_range
    phi = RNG.uniform(lo + 0.5 * (hi - lo), hi - 1e-3, 20)
    uz, wz = RNG.uniform(0.5, 1, 20), RNG.uniform(-0.05, 0.05, 20)
    base = r.stress(phi, uz, wz)
    for lam in (0.1, 7.0):
        for x, y in zip(r.stress(phi, lam * uz, lam * wz), base):
            np.testing.assert_allclose(x, lam**2 * y, rtol=1e-12)


def test_nonmonotonic_friction_has_the_stated_minimum():
    law = NonMonotonicMu()
    mat = Material(friction=law.name)
    I = np.linspace(1e-4, 0.2, 20001)  # noqa: E741
    mu = mat.mu(I)
    i = int(np.argmin(mu))
    assert I[i] == pytest.approx(0.0124, abs=2e-4) and mu[i] == pytest.approx(0.319, abs=1e-3)
    assert mat.mu(np.array([0.0]))[0] == pytest.approx(0.348)
    assert float(mat.Phi(np.array(I[i]))) == pytest.approx(0.8131, abs=1e-4)
    with pytest.raises(ValueError, match=r"`delta_mu` must lie in \[0, 1 - mu_s\).*got 0.9"):
        NonMonotonicMu(delta_mu=0.9)


@pytest.mark.parametrize("name", ["icidr-blended", "icidr-blended-half"])
def test_blended_steady_pressure_is_7_2_and_caps_at_p_itm(name):
    """At div u = 0 the pressure is (7.2) with (7.3) (k/d = 1e4, alpha = 1), -> p_itm at and beyond phi_c."""
    r = get_rheology(name)
    phi_c, a = 0.817, 0.314
    phi = np.array([0.70, 0.78, 0.81, 0.8165, 0.817, 0.83, 0.85])
    gdot = 1.0 / 30.0
    p, c = r.invariant_stress(phi, 0 * phi, np.full_like(phi, gdot / 2))
    psi = np.maximum((phi_c - phi) / a, 0)
    with np.errstate(divide="ignore"):
        p_inert = (gdot / psi) ** 2
    p_itm = ALPHA_ITM * K_OVER_D**0.75 * np.sqrt(gdot)
    with np.errstate(invalid="ignore"):
        p_blend = np.where(psi > 0, p_inert * p_itm / (p_inert + p_itm), p_itm)
    np.testing.assert_allclose(p, p_blend, rtol=1e-12)
    # friction: ||tau|| = mu(Psi_+) p at the steady state, mu_s beyond phi_c
    mu = c * (gdot / 2) / p
    np.testing.assert_allclose(mu, Material().mu(psi), rtol=1e-12)
    # far from phi_c the blend is iCIDR's pressure (the cap is negligible)
    ic = get_rheology("icidr")
    q = ic.invariant_stress(np.array([0.70]), np.array([-0.01]), np.array([gdot / 2]))[0]
    qb = r.invariant_stress(np.array([0.70]), np.array([-0.01]), np.array([gdot / 2]))[0]
    assert qb == pytest.approx(q, rel=1e-3)


def test_invariant_kernels_of_every_shipped_law_are_finite_where_shearing():
    for name in ("icidr", "icidr-nonmonotonic", "icidr-saturating-phi", "icidr-blended", "mui"):
        r = get_rheology(name)
        lo, hi = getattr(r, "phi_domain", lambda: r.material.phi_range)()
        phi = np.linspace(lo, hi, 12)[1:-1]
        for div in (-1.0, 0.0, 1.0):
            out = r.kernels(INVARIANTS).stress_jacobian_numpy(phi, div + 0 * phi, 0.3 + 0 * phi, r.material.params)
            assert all(np.all(np.isfinite(o)) for o in out), name


def test_derived_icidr_run_reproduces_the_max_w_series(derived_icidr):
    """The whole run path with the derived law: max|w|(t) equal to today's iCIDR to round-off."""
    from icidr_pde import run

    kw = dict(N=41, t_end=2.0, times=[0, 0.5, 1, 2], method="BDF", rtol=1e-8, atol=1e-11)
    a = run("icidr-derived-test", "shear", **kw)
    b = run("icidr", "shear", **kw)
    np.testing.assert_allclose(a.max_w_series, b.max_w_series, rtol=1e-7, atol=1e-12)


@pytest.mark.slow
def test_mui_through_the_workbench_reproduces_t_star():
    """mu(I),Phi(I) as a direct (p, ||tau||) law: Chebyshev N = 201 fails at the anchor t* = 0.01058."""
    from icidr_pde import run

    p = (2 * s.norm_S / s.Psi) ** 2
    define_direct_law("mui-direct-tstar-test", p, s.M * p)
    kw = dict(N=201, t_end=0.05, discretization="cheb", method="BDF", rtol=1e-6, atol=1e-9)
    a, b = run("mui-direct-tstar-test", "shear", **kw), run("mui", "shear", **kw)
    assert a.blew_up and a.t_star == b.t_star and round(a.t_star, 5) == 0.01058
