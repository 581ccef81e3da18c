"""Appendix A for mu(I),Phi(I): (A10)-(A18) statuses and chi against independent numbers."""

import numpy as np
import pytest

from stability import mui
from stability.numeric import coefficients, gamma


def test_appendix_A_statuses(checks_by_eq):
    for eq in ("(A10)", "(A12)", "(A13)", "(A14)", "(A9) mu(I)", "(A15)", "(A16)", "(A17)", "(A18)",
               "(3.5)", "(3.6)", "(3.8)"):
        assert checks_by_eq[eq][0].status == "exact", eq
    # the alternative reading of (A14) (M sqrt(u_z^2+w_z^2) in place of M||S||) is wrong
    assert "is WRONG" in checks_by_eq["(A14)"][0].detail


def _fd_gamma(phi, uz, wz, h=1e-6):
    """Gamma from central differences of the *simulator's* stress (independent of sympy)."""
    import icidr_pde.rheology as rheo
    sim = rheo.get_rheology("mui")

    def F(u, w):
        p, txz, tzz = sim.stress(phi, u, w)
        return np.array([txz, tzz - p], float)

    col_u = (F(uz + h, wz) - F(uz - h, wz)) / (2 * h)
    col_w = (F(uz, wz + h) - F(uz, wz - h)) / (2 * h)
    return np.column_stack([col_u, col_w]) / phi


def test_chi_sign_matches_det_gamma_sign():
    """(A18) <=> (A16): sign(chi) = -sign(det Gamma) at random states (M < 1, u_z != 0)."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        ph = rng.uniform(0.6, 0.81)
        u, w = rng.normal(size=2)
        chi = float(mui.chi(ph, u, w))
        G = _fd_gamma(ph, u, w)
        det = np.linalg.det(G)
        if abs(chi) > 1e-6:
            assert np.sign(chi) == -np.sign(det)
        lam_max = np.linalg.eigvals(-G).real.max()
        assert (lam_max > 0) == (chi > 0)        # ill-posed iff chi > 0 (roots are real, (A14))


def test_chi_where_u_z_vanishes():
    """u_z = 0: (A16) holds iff w_z > 0 (w_z/sqrt(u_z^2 + w_z^2) = 1 > M), so chi = +inf there and
    -inf for w_z < 0; at u_z = w_z = 0 Gamma = 0 and neither (A16) nor (A17) holds: nan."""
    chi = mui.chi(np.full(3, 0.78), np.zeros(3), np.array([0.2, -0.2, 0.0]))
    assert chi[0] == np.inf and chi[1] == -np.inf and np.isnan(chi[2])
    G = _fd_gamma(0.78, 0.0, 0.2)
    assert np.linalg.eigvals(-G).real.max() > 0  # ill-posed where chi = +inf


def test_chi_on_fields_and_limits():
    z = np.linspace(0, 30, 7)
    chi = mui.chi(np.full_like(z, 0.78), np.array([0, 1, -1, 0, 0.1, 0.1, 0.1]), np.array([1, 0, 0, -1, 0, 1, -1.0]))
    assert chi.shape == z.shape
    assert chi[0] == np.inf and chi[3] == -np.inf and chi[5] > 0 and chi[6] < 0
    with pytest.raises(ValueError, match="phi"):
        mui.chi(0.9, 1.0, 1.0)


def test_sympy_gamma_equals_finite_difference_gamma():
    rng = np.random.default_rng(5)
    for _ in range(20):
        ph, u, w = rng.uniform(0.6, 0.81), *rng.normal(size=2)
        G = gamma(coefficients("mui", ph, u, w))
        assert np.allclose(G, _fd_gamma(ph, u, w), rtol=1e-6, atol=1e-8 * np.abs(G).max())
