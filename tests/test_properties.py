"""Property-based tests (hypothesis) of the stress laws and of the input validation.

Invariants of the two rheologies in the shear cell, over the whole inertial range
0 < phi < phi_c and strain rates spanning many decades:

* p >= 0 and every output finite;
* p = 0 exactly on the zero-pressure set (4.13): ||S|| = 0 and div u = w_z >= 0
  (mu(I),Phi(I): exactly where ||S|| = 0);
* degree-2 homogeneity in the strain rate: p(lambda S) = lambda^2 p(S), tau likewise
  (both laws are rate-independent in I = 2||S||/sqrt(p/rho) and quadratic in p);
* iCIDR equals mu(I),Phi(I) where div u = 0 (section 4);
* non-negative dissipation: tau:S >= 0 for both laws, and the whole stress power
  sigma:grad u = tau_xz u_z + (tau_zz - p) w_z >= 0 for iCIDR (a CIDR law, appendix B);
* the numba-compiled kernels equal the numpy ones.

The validation properties: any non-number, non-finite or out-of-range value of a public
parameter is refused before any work with a ValueError naming the parameter.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from icidr_pde import run
from icidr_pde.rheology import Material, get_rheology

MAT = Material()
RHEOLOGIES = ("mui", "icidr")
PROFILE = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])

phis = st.floats(min_value=1e-6, max_value=MAT.phi_c, exclude_max=True, allow_nan=False)
# strain rates from 1e-100 to 1e100 in magnitude, both signs, and exact zeros
magnitudes = st.floats(min_value=-100, max_value=100).map(lambda e: 10.0**e)
rates = st.one_of(st.just(0.0), st.tuples(magnitudes, st.sampled_from([-1.0, 1.0])).map(lambda t: t[0] * t[1]))
# |rates| in [1e-50, 1e3] or 0: scaled by lambda in [1e-30, 1e30] the pressure stays a normal float
moderate = st.one_of(st.just(0.0), st.tuples(st.floats(min_value=-50, max_value=3).map(lambda e: 10.0**e),
                                             st.sampled_from([-1.0, 1.0])).map(lambda t: t[0] * t[1]))


def stress(name, phi, uz, wz):
    return [float(x) for x in get_rheology(name, MAT).stress(phi, uz, wz)]


@PROFILE
@given(name=st.sampled_from(RHEOLOGIES), phi=phis, uz=rates, wz=rates)
def test_pressure_non_negative_and_finite(name, phi, uz, wz):
    p, txz, tzz = stress(name, phi, uz, wz)
    assert all(math.isfinite(x) for x in (p, txz, tzz))
    assert p >= 0


@PROFILE
@given(name=st.sampled_from(RHEOLOGIES), phi=phis, uz=rates, wz=rates)
def test_zero_pressure_exactly_on_the_zero_pressure_set(name, phi, uz, wz):
    """(4.13): iCIDR's p vanishes iff ||S|| = 0 and div u >= 0 (and mu(I)'s iff ||S|| = 0);
    here ||S|| = 0 iff u_z = w_z = 0, and div u = w_z."""
    p, _, _ = stress(name, phi, uz, wz)
    at_rest = uz == 0 and wz == 0
    assert (p == 0) == at_rest


@PROFILE
@given(name=st.sampled_from(RHEOLOGIES), phi=phis, uz=moderate, wz=moderate,
       lam=st.floats(min_value=1e-30, max_value=1e30))
def test_degree_two_homogeneity(name, phi, uz, wz, lam):
    base = np.array(stress(name, phi, uz, wz))
    scaled = np.array(stress(name, phi, lam * uz, lam * wz))
    normal = np.finfo(float).tiny * 1e10  # subnormal results carry fewer digits
    assume(np.all((base == 0) | (np.abs(base) * min(lam**2, 1) > normal)))
    np.testing.assert_allclose(scaled, lam**2 * base, rtol=1e-12, atol=0)


@PROFILE
@given(phi=phis, uz=rates)
def test_icidr_equals_mui_without_dilation(phi, uz):
    np.testing.assert_allclose(stress("icidr", phi, uz, 0.0), stress("mui", phi, uz, 0.0),
                               rtol=1e-13, atol=0)


@PROFILE
@given(name=st.sampled_from(RHEOLOGIES), phi=phis, uz=moderate, wz=moderate)
def test_dissipation_non_negative(name, phi, uz, wz):
    p, txz, tzz = stress(name, phi, uz, wz)
    shear_power = txz * uz + tzz * wz  # tau:S up to a positive factor (tau = c S)
    assert shear_power >= 0
    if name == "icidr":
        total = shear_power - p * wz
        assert total >= -1e-12 * (shear_power + p * abs(wz))


@pytest.fixture(scope="module")
def compiled_kernels():
    return {name: get_rheology(name).kernels().stress_array for name in RHEOLOGIES}


@PROFILE
@given(name=st.sampled_from(RHEOLOGIES),
       points=st.lists(st.tuples(phis, moderate, moderate), min_size=1, max_size=20))
def test_numba_equals_numpy(compiled_kernels, name, points):
    phi, uz, wz = (np.array(c, dtype=float) for c in zip(*points))
    expected = get_rheology(name, MAT).kernels().stress_numpy(phi, uz, wz, MAT.params)
    got = compiled_kernels[name](phi, uz, wz, MAT.params)
    for a, b in zip(got, expected):
        np.testing.assert_allclose(a, b, rtol=1e-14, atol=0)


# --- input validation ---------------------------------------------------------------

non_numbers = st.one_of(st.text(max_size=5), st.lists(st.integers(), max_size=2),
                        st.just(float("nan")), st.just(float("inf")), st.just(-float("inf")))


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(["t_end", "rtol", "atol", "phi0", "eps", "H", "N"]), value=non_numbers)
def test_run_refuses_non_numbers_naming_the_parameter(name, value):
    """(None is not among the values: it means 'from the preset' for N, rtol and atol.)"""
    kwargs = dict(rheology="icidr", scene="shear", N=21, t_end=1.0)
    kwargs[name] = value
    with pytest.raises(ValueError, match=f"`{name}`") as info:
        run(**kwargs)
    assert repr(value)[:20] in str(info.value) or str(value) in str(info.value)


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(["t_end", "rtol", "atol", "H"]),
       value=st.floats(max_value=0.0, allow_nan=False, allow_infinity=False))
def test_run_refuses_non_positive_values(name, value):
    kwargs = dict(rheology="icidr", scene="shear", N=21, t_end=1.0)
    kwargs[name] = value
    with pytest.raises(ValueError, match=f"`{name}`"):
        run(**kwargs)


@settings(max_examples=60, deadline=None)
@given(value=st.one_of(st.floats(allow_nan=True), st.integers(max_value=3)))
def test_run_refuses_bad_grid_sizes(value):
    assume(not (isinstance(value, float) and value.is_integer() and 4 <= value <= 100_000))
    with pytest.raises(ValueError, match="`N`"):
        run("icidr", "shear", N=value, t_end=1.0)


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(["mu_s", "mu_d", "I0", "phi_c", "a"]), value=non_numbers)
def test_material_refuses_non_numbers_naming_the_parameter(name, value):
    with pytest.raises(ValueError, match=f"`{name}`"):
        Material(**{name: value})


@settings(max_examples=40, deadline=None)
@given(kind=st.sampled_from([int, np.int64, np.int32, np.float32, float]))
def test_material_accepts_every_real_number_type(kind):
    m = Material(I0=kind(1))
    assert m.I0 == 1 and isinstance(m.params[2], float)
