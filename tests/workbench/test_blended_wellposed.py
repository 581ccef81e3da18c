"""icidr-blended: the blended pressure (7.2)-(7.3) as a well-posed CIDR law, against independent truth.

(4.3)-(4.5) and Y > 0 by sympy and on a grid far wider than the workbench sample; the flow rule's
root by mpmath's polynomial roots; iCIDR (4.7)-(4.8) recovered where P = p_inert, with the error
falling in proportion to omega = P/p_itm; runs across phi_c (tests/workbench/test_runs.py).
"""

import mpmath
import numpy as np
import pytest
import sympy as sp

from icidr_pde.rheology import Material, get_rheology
from icidr_pde.rheology import symbols as s
from icidr_pde.rheology.blended import ALPHA_ITM, K_OVER_D, KAPPA
from icidr_pde.rheology.cidr import pressure_symbol
from stability import workbench as wb

PHI_C, A = 0.817, 0.314
BETA = ALPHA_ITM * K_OVER_D**0.75


def steady_P(psi, gdot):
    p_itm = BETA * np.sqrt(gdot)
    return gdot**2 * p_itm / (gdot**2 + psi**2 * p_itm)


@pytest.mark.slow  # one report deciding (4.3) and (4.5) by sympy's simplification: 14-40 s on 2 cores
def test_every_condition_holds_and_the_report_says_well_posed():
    # one report: it decides (4.3)-(4.5) and Y > 0 itself (each a symbolic simplification of ~20 s)
    report = wb.law_report("icidr-blended", with_curves=False)
    c = report["conditions"]
    assert c["(4.3)"]["status"] == "holds" and c["(4.3)"]["method"] == "symbolic"
    assert c["(4.5)"]["status"] == "holds" and c["(4.5)"]["method"] == "symbolic"
    assert c["(4.4)"]["status"] == "holds"
    assert report["positivity"]["status"] == "holds"
    assert report["well_posed"] is True
    assert report["stability"]["one_d"]["well_posed"] is True and report["stability"]["two_d"]["well_posed"] is True


@pytest.mark.parametrize("psi", [0.3, 0.05, 0.0])
def test_yield_increases_with_I_and_is_positive_from_strong_dilation_to_strong_compaction(psi):
    """dY/dI > 0 and Y > 0 by sympy's derivative of Y on gamma-dot in [1e-8, 1e8] (omega from ~0 to ~1)
    and r = p/P in [1e-12, 1e12]: where the half-power law fails (4.4) (r >> 1, 0 < omega < 1)."""
    Y, _ = get_rheology("icidr-blended").symbolic_yield(symbolic_material=True)
    p = pressure_symbol()
    Y = Y.subs({s.M: 1, s.Psi: psi})
    Y_I = sp.lambdify((p, s.I), sp.diff(Y, s.I), "numpy")
    Y_n = sp.lambdify((p, s.I), Y, "numpy")
    g, r = np.meshgrid(np.logspace(-8, 8, 161), np.logspace(-12, 12, 97))
    pv = r * steady_P(psi, g)
    Iv = g / np.sqrt(pv)
    assert np.all(Y_I(pv, Iv) > 0) and np.all(Y_n(pv, Iv) > 0)


@pytest.mark.parametrize("psi", [0.3, 0.05, 0.0])
def test_43_vanishes_and_45_is_negative_from_strong_dilation_to_strong_compaction(psi):
    """(4.3) dY/dp - I/(2p) dY/dI = f + I df/dI to round-off, and (4.5) df/dp - I/(2p) df/dI < 0, by sympy's
    derivatives of the law's Y and f on the grid of the (4.4) test; the symbol of the workbench's state grid
    is negative in 1-D and 2-D (the whole report, which decides (4.3) and (4.5) by sympy, is in the slow run)."""
    rheology = get_rheology("icidr-blended")
    Y, f = rheology.symbolic_yield(symbolic_material=True)
    p = pressure_symbol()
    Y, f = (e.subs({s.M: 0.3, s.Psi: psi}) for e in (Y, f))
    terms = [sp.diff(Y, p), -s.I / (2 * p) * sp.diff(Y, s.I), -f, -s.I * sp.diff(f, s.I)]
    terms = [sp.lambdify((p, s.I), t, "numpy") for t in terms]
    c45 = sp.lambdify((p, s.I), sp.diff(f, p) - s.I / (2 * p) * sp.diff(f, s.I), "numpy")
    g, r = np.meshgrid(np.logspace(-8, 8, 161), np.logspace(-12, 12, 97))
    pv = r * steady_P(psi, g)
    Iv = g / np.sqrt(pv)
    values = np.array([np.broadcast_to(t(pv, Iv), pv.shape) for t in terms])
    assert np.all(np.abs(values.sum(axis=0)) <= 1e-9 * np.abs(values).sum(axis=0))
    assert np.all(c45(pv, Iv) < 0)
    if psi == 0.3:
        grid = wb.symbol_grid(rheology).to_json()
        assert grid["one_d"]["well_posed"] is True and grid["two_d"]["well_posed"] is True


def _pressure_by_polyroots(phi, div_u, norm_S):
    """Flow rule (4.2): with x = sqrt(p/P), 2||S|| [c1 (1 - x^2) + c2 (1 - x^5)] = div u x (times x)."""
    mat = Material(dilatancy="linear-to-jamming")
    psi, M = float(mat.Psi(phi)), float(mat.M(phi))
    g = 2 * norm_S
    P = steady_P(psi, g)
    omega = P / (BETA * np.sqrt(g))
    c1, c2 = M * np.sqrt(1 - omega) / 4, M * KAPPA * omega**2
    coeffs = [-2 * norm_S * c2, 0, 0, -2 * norm_S * c1, -div_u, 2 * norm_S * (c1 + c2)]   # x^5 ... x^0
    roots = [complex(z) for z in mpmath.polyroots(coeffs, maxsteps=200, extraprec=200)]
    x = [z.real for z in roots if abs(z.imag) < 1e-12 and z.real > 0]
    assert len(x) == 1
    return x[0] ** 2 * P


@pytest.mark.parametrize("phi", [0.70, 0.80, 0.8165, 0.83])
def test_pressure_is_the_positive_root_of_the_quintic_flow_rule(phi):
    r = get_rheology("icidr-blended")
    for div_u in (-1.0, -0.01, 0.0, 0.2, 3.0):
        for norm_S in (1e-3, 1 / 60, 0.5):
            p, _ = r.invariant_stress(np.array([phi]), np.array([div_u]), np.array([norm_S]))
            assert p[0] == pytest.approx(_pressure_by_polyroots(phi, div_u, norm_S), rel=1e-12)


def test_is_icidr_where_the_inertial_pressure_is_far_below_the_cap():
    """Where omega = P/p_itm -> 0 at fixed div u/||S|| (so fixed p/P), (p, c) -> iCIDR's (4.12), (4.14); the
    difference falls as omega (order 1). (At fixed div u > 0 it does not: as p/P -> 0, Y -> (M - K) P, O(omega) P,
    while iCIDR's Y -> 0.)"""
    blend, icidr = get_rheology("icidr-blended"), get_rheology("icidr")
    phi = np.array([0.70, 0.75, 0.78])
    ratio = np.array([-1.2, 0.0, 0.6])
    errs, omegas = [], []
    for norm_S in (1 / 60, 1 / 240, 1 / 960):
        S = np.full(3, norm_S)
        div_u = ratio * S
        pb, cb = blend.invariant_stress(phi, div_u, S)
        pi, ci = icidr.invariant_stress(phi, div_u, S)
        psi = (PHI_C - phi) / A
        omegas.append(np.max(steady_P(psi, 2 * norm_S) / (BETA * np.sqrt(2 * norm_S))))
        errs.append(max(np.max(np.abs(pb / pi - 1)), np.max(np.abs(cb / ci - 1))))
    errs, omegas = np.array(errs), np.array(omegas)
    assert errs[0] < 1e-2
    order = np.log(errs[:-1] / errs[1:]) / np.log(omegas[:-1] / omegas[1:])
    assert np.all(np.abs(order - 1) < 0.1), order


def test_beyond_phi_c_the_law_is_the_intermediate_regime_one():
    """Psi_+ = 0: omega = 1, f = kappa M (r^(-1/2) - r^2), Y = (M - K) P + K sqrt(p P), K = 5 kappa M/2, P = p_itm."""
    Y, f = get_rheology("icidr-blended").symbolic_yield(symbolic_material=True)
    p, M = pressure_symbol(), s.M
    P = BETA * sp.sqrt(s.I * sp.sqrt(p))
    r = p / P
    K = sp.Rational(5, 2) * sp.nsimplify(KAPPA) * M
    for got, want in ((f, sp.nsimplify(KAPPA) * M * (1 / sp.sqrt(r) - r**2)), (Y, (M - K) * P + K * sp.sqrt(p * P))):
        got = sp.lambdify((p, s.I, M), got.subs(s.Psi, 0), "numpy")
        want = sp.lambdify((p, s.I, M), sp.nsimplify(want), "numpy")
        pv, Iv = np.meshgrid(np.logspace(-3, 6, 19), np.logspace(-4, 1, 11))
        want_v = want(pv, Iv, 0.3)
        np.testing.assert_allclose(got(pv, Iv, 0.3), want_v, rtol=1e-12, atol=1e-14 * np.abs(want_v).max())


@pytest.mark.slow  # two scipy-BDF runs with a law compiled for them alone: ~35 s
def test_shear_cell_far_from_phi_c_is_icidrs():
    """phi0 = 0.78, gamma-dot = 1/30: omega ~ 4e-4, and the run's max|w| is iCIDR's to that order."""
    from icidr_pde import run

    kw = dict(N=33, t_end=1.0, times=[0, 0.5, 1], method="BDF", rtol=1e-8, atol=1e-11)
    wb_, wi = run("icidr-blended", "shear", **kw).max_w_at_times(), run("icidr", "shear", **kw).max_w_at_times()
    for t in ("0.5", "1"):
        assert wb_[t] == pytest.approx(wi[t], rel=5e-3)
        assert wb_[t] != wi[t]
