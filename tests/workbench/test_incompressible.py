"""Incompressible mu(I) in 2-D (stability.incompressible): the symbol derived by sympy against its closed
form and the criterion of Barker et al. (2015); ill-posed wherever friction decreases."""

import numpy as np
import pytest

from icidr_pde.rheology import Material
from stability import incompressible as inc

MATERIALS = {"table1": Material(), "non-monotonic": Material(friction="non-monotonic")}


@pytest.mark.parametrize("name", list(MATERIALS))
def test_derived_symbol_is_the_closed_form(name):
    mat = MATERIALS[name]
    I = np.logspace(-4, 0.5, 10)[:, None]  # noqa: E741
    th = np.linspace(0, 180, 37)[None, :]
    a, b = inc.sigma(I, th, mat), inc.sigma_closed_form(I, th, mat)
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("name", list(MATERIALS))
def test_barker_criterion_decides_where_the_derived_symbol_is_negative(name):
    mat = MATERIALS[name]
    I = np.logspace(-5, 1, 200)  # noqa: E741
    numeric = inc.sigma(I[:, None], np.linspace(0, 180, 3601)[None, :], mat).min(axis=1) < 0
    nu, _ = inc.friction_slope(I, mat)
    assert np.all(nu <= 0.5)                    # the minimiser lies in [-1, 1]: Barker's form applies
    np.testing.assert_array_equal(numeric, inc.ill_posed(I, mat))
    np.testing.assert_array_equal(numeric, inc.barker_criterion(I, mat) > 0)


def test_decreasing_friction_is_ill_posed_incompressible():
    """The non-monotonic mu decreases for I < I_min = 0.0124: every such I is ill-posed (nu < 0: N(0) = nu)."""
    mat = MATERIALS["non-monotonic"]
    I = np.logspace(-5, np.log10(0.0123), 50)  # noqa: E741
    nu, _ = inc.friction_slope(I, mat)
    assert np.all(nu < 0) and np.all(inc.ill_posed(I, mat))
    assert np.all(inc.sigma(I, 0.0, mat) < 0)   # theta = 0: the shear wave along the flow
    (lo, hi), = inc.well_posed_intervals(mat)
    assert 0.0124 < lo < hi < 1


def test_table1_friction_well_posed_window():
    """(2.10), Table 1: nu -> 0 at both ends, so ill-posed at small and large I, well-posed in between."""
    (lo, hi), = inc.well_posed_intervals(MATERIALS["table1"])
    for I, bad in ((0.5 * lo, True), (2 * lo, False), (0.5 * hi, False), (2 * hi, True)):  # noqa: E741
        assert bool(inc.ill_posed(np.array([I]), MATERIALS["table1"])[0]) is bad


@pytest.mark.parametrize("I, theta", [(0.005, 0.0), (0.005, 30.0), (0.1, 100.0), (2.0, 45.0)])
def test_measured_growth_of_the_full_linearisation_is_the_symbol(I, theta):  # noqa: E741
    """max Re lambda of the whole frozen-coefficient system (advection, L u', pressure) -> -xi^2 sigma:
    the error falls like 1/xi^2 (measured at xi = 100 and 1000)."""
    mat = MATERIALS["non-monotonic"]
    s = float(inc.sigma(I, theta, mat))
    errs = [abs(inc.growth_rate(I, theta, xi, mat) / xi**2 + s) for xi in (100.0, 1000.0)]
    assert errs[1] < 1e-5 * max(abs(s), 1.0) and errs[1] < 0.012 * errs[0] + 1e-12
    if I == 0.005 and theta == 0.0:                           # decreasing friction: a growing mode
        assert inc.growth_rate(I, theta, 1000.0, mat) > 0
