"""Section 5: iCIDR stress vs (5.1), (5.2), (5.6); well-posedness proof; degeneracy at 0."""

import numpy as np
import pytest
import sympy as sp

from stability import icidr, rheologies
from stability.numeric import coefficients, gamma
from stability.symbols import Mf, Psif, d, phi, rho, uz, wz


def test_51_and_56_fail_with_the_correct_expression(checks_by_eq):
    for eq in ("(5.1)", "(5.6)"):
        (c,) = checks_by_eq[eq]
        assert c.status == "fails"
        assert "(u_z^2 + w_z^2)/4" in c.corrected
    # independent confirmation: printed (5.1) is not even dimensionally homogeneous --
    # scaling the strain rates by k does not scale it by k^2, unlike (4.12)
    k = sp.Symbol("k", positive=True)
    pr = icidr.printed_51()
    p, _, _ = rheologies.icidr_stress()
    scaled = lambda e: e.subs({uz: k * uz, wz: k * wz}, simultaneous=True)  # noqa: E731
    assert sp.simplify(scaled(p) - k**2 * p) == 0
    val = (scaled(pr) - k**2 * pr).subs({k: 2, uz: 1, wz: sp.Rational(1, 3), d: 1, rho: 1}).subs(
        {Mf(phi): sp.Rational(2, 5), Psif(phi): sp.Rational(1, 10)})
    assert abs(float(val)) > 1e-3


def test_52_and_flux_forms_hold(checks_by_eq):
    assert checks_by_eq["(5.2)"][0].status == "exact"
    assert checks_by_eq["(5.4)-(5.5)"][0].status == "exact"


def test_wellposedness_proof(checks_by_eq):
    assert checks_by_eq["(A5) iCIDR symmetric"][0].status == "exact"
    assert checks_by_eq["sec. 5 well-posed"][0].status == "exact"
    tr, det, polys = icidr.wellposedness_proof()
    for num, den, coeffs in polys:
        assert all(c.is_positive for c in coeffs)


def test_gamma_positive_definite_numerically_including_extreme_states():
    """numpy eigenvalues of Gamma (from the simulator's stress by finite differences) are > 0."""
    import icidr_pde.rheology as rheo
    sim = rheo.get_rheology("icidr")
    rng = np.random.default_rng(6)
    angles = np.concatenate([rng.uniform(0, 2 * np.pi, 200), [0, np.pi / 2, np.pi, 3 * np.pi / 2]])
    for th in angles:
        ph = rng.uniform(0.55, 0.8169)
        r = 10 ** rng.uniform(-3, 1)
        u, w = r * np.cos(th), r * np.sin(th)
        G = gamma(coefficients("icidr", ph, u, w))
        assert np.allclose(G, G.T, rtol=1e-10, atol=1e-14 * np.abs(G).max())
        ev = np.linalg.eigvalsh((G + G.T) / 2)
        assert ev.min() > 0
        h = 1e-6 * r

        def F(a, b):
            p, txz, tzz = sim.stress(ph, a, b)
            return np.array([txz, tzz - p], float)

        Gfd = np.column_stack([(F(u + h, w) - F(u - h, w)) / (2 * h), (F(u, w + h) - F(u, w - h)) / (2 * h)]) / ph
        assert np.allclose(G, Gfd, rtol=1e-5, atol=1e-6 * np.abs(G).max())


def test_origin_is_degenerate(checks_by_eq):
    assert checks_by_eq["sec. 5 (u_z = w_z = 0)"][0].status == "exact"
    # Gamma shrinks linearly towards the origin along any ray
    base = gamma(coefficients("icidr", 0.78, 0.3, -0.4))
    for s in (1e-2, 1e-4):
        assert np.allclose(gamma(coefficients("icidr", 0.78, 0.3 * s, -0.4 * s)), s * base, rtol=1e-9)
    with pytest.raises(ValueError, match="uz"):
        coefficients("icidr", 0.78, 0.0, 0.0)
