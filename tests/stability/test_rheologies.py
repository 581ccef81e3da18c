"""Symbolic rheologies: kinematics, cross-check with the simulator's numeric stress, validation."""

import numpy as np
import pytest
import sympy as sp

from stability import rheologies
from stability.symbols import uz, wz


def test_kinematics_match_34_35(checks_by_eq):
    k = rheologies.shear_cell_kinematics()
    # (3.4): independent construction from the definition S = D - (tr D/2) Id with D = sym(grad u)
    assert sp.simplify(k["normS"] - sp.sqrt(uz**2 + wz**2) / 2) == 0
    assert k["div"] == wz
    assert checks_by_eq["(3.4)"][0].status == "exact"
    assert checks_by_eq["(2.13)"][0].status == "exact"


def test_printed_momentum_index_form_is_wrong(checks_by_eq):
    (c,) = checks_by_eq["(2.2)"]
    assert c.status == "fails" and "d_j sigma_ij" in c.corrected


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_symbolic_stress_equals_simulator_stress(name):
    """The simulator's hand-written kernels agree with the one symbolic definition to 1e-12."""
    import icidr_pde.rheology as rheo
    sim = rheo.get_rheology(name)
    rng = np.random.default_rng(42)
    n = 2000
    ph = rng.uniform(0.5, 0.816, n)
    u = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 1, n)
    w = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 1, n)
    mine = rheologies.numeric_stress(name, ph, u, w, sim.material)
    theirs = sim.stress(ph, u, w)
    for a, b in zip(mine, theirs):
        scale = np.maximum(np.abs(a), np.abs(mine[0]))
        assert np.all(np.abs(a - b) <= 1e-12 * scale + 1e-300)


def test_default_material_is_simulators_or_table1():
    from stability.material import TABLE1, material_params

    assert material_params() == pytest.approx(TABLE1)


@pytest.mark.parametrize("bad", [0.0, -0.1, 0.817, 0.9, float("nan")])
def test_numeric_stress_rejects_phi_outside_range(bad):
    with pytest.raises(ValueError, match=r"phi.*\(0, phi_c\)"):
        rheologies.numeric_stress("icidr", bad, 0.1, 0.1)


def test_numeric_stress_rejects_bad_rate_and_name():
    with pytest.raises(ValueError, match="uz"):
        rheologies.numeric_stress("mui", 0.7, np.inf, 0.1)
    with pytest.raises(ValueError, match="rheology"):
        rheologies.numeric_stress("newtonian", 0.7, 0.1, 0.1)


def test_icidr_pressure_zero_set_4_13():
    """(4.13): p = 0 iff ||S|| = 0 and div u >= 0.  In the shear cell ||S|| = |(u_z, w_z)|/2, so p = 0 only at
    the origin; for general deformations p(||S|| = 0) = 0 for div u >= 0 and > 0 for div u < 0."""
    p, _, _ = rheologies.numeric_stress("icidr", np.full(4, 0.78), np.array([0, 0, 0, 1e-3]),
                                        np.array([0.0, 0.5, -0.5, 0.0]))
    assert p[0] == 0 and np.all(p[1:] > 0)
    from stability import cidr
    from stability.symbols import M, Psi, Sn, d, delta, rho

    f = sp.lambdify((delta, Sn, M, Psi), cidr.icidr_pressure(delta, Sn, M, Psi).subs({d: 1, rho: 1}), "numpy")
    assert f(0.5, 0.0, 0.4, 0.1) == 0 and f(0.0, 0.0, 0.4, 0.1) == 0 and f(-0.5, 0.0, 0.4, 0.1) > 0


def test_simulator_laws_match_their_derivations(checks_by_eq):
    """The simulator's one definition of each law, on general (div u, ||S||), against (2.9)/(2.14),
    (4.7)-(4.11) derived in stability.cidr, and its cancellation-free form against the plain one."""
    assert checks_by_eq["(2.14) simulator"][0].status == "exact"
    assert checks_by_eq["(4.12) simulator"][0].status == "exact"
    assert checks_by_eq["(4.14) simulator"][0].status in ("exact", "numeric")
    assert checks_by_eq["(4.12) stable form"][0].status == "exact"
