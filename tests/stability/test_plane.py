"""2-D plane-wave principal part: symbolic identities (stability.plane)."""

import pytest
import sympy as sp

from stability import plane
from stability.symbols import M, Psi, phi, rho


#: one worker under pytest-xdist: the module's fixtures are built once, not once per worker
pytestmark = pytest.mark.xdist_group("plane_symbols")


@pytest.fixture(scope="module")
def plane_checks():
    return {c.equation: c for c in plane.checks()}


@pytest.mark.parametrize("eq", ["2-D theta = 90", "2-D Gamma(n)", "2-D mu(I) eig", "2-D iCIDR Gamma"])
def test_plane_identities_are_exact(plane_checks, eq):
    assert plane_checks[eq].status == "exact", plane_checks[eq].detail


def test_identity_test_can_fail():
    """The reduction used by the checks rejects a wrong eigenvalue (a perturbed closed form)."""
    G, n = plane.point_gamma("mui")
    subs, _ = plane.gradient_parametrisation()
    l1, l2 = (e.subs(subs) for e in plane.mui_eigen_closed_form(n))
    assert plane._vanishes(G.trace() + l1 + l2, subs)
    assert not plane._vanishes(G.trace() + l1 + l2 * (1 + sp.Rational(1, 1000)), subs)


def test_newtonian_law_gives_navier_stokes_symbol():
    """User law sigma = -p(phi) I + 2 eta S + zeta div u I: Gamma = (eta I + zeta n n^T)/(rho phi) (Navier-Stokes)."""
    eta, zeta = sp.symbols("eta zeta", positive=True)
    p0 = sp.Function("p0")
    law = plane.InvariantLaw("newtonian", lambda ph, dv, sn: (p0(ph) - zeta * dv, 2 * eta))
    a, B = plane.principal_part(plane.stress_tensor(law))
    n = plane.direction()
    G = plane.acoustic_tensor(B, n)
    target = (eta * sp.eye(2) + zeta * n * n.T) / (rho * phi)
    assert all(sp.simplify(x) == 0 for x in (G - target))
    al = plane.phi_coupling(a, n)
    assert all(sp.simplify(x) == 0 for x in (al + sp.diff(p0(phi), phi) * n / (rho * phi)))


def test_icidr_smallest_eigenvalue_is_isotropic_shear_viscosity():
    """Lambda_max = -c/(2 rho phi): the closed form's smallest eigenvalue is the tau = c S coefficient over 2 rho phi."""
    k = plane.kinematics()
    p, c = plane.toolkit_law("icidr", M, Psi).symbolic_stress(phi, k["div"], k["normS"])
    _, q, R, _ = plane.icidr_gamma_closed_form(plane.direction())
    assert sp.simplify(c / (2 * rho * phi) - 2 * plane.d**2 * q / (phi * Psi**2)) == 0


def test_toolkit_law_in_shear_cell_matches_1d_stresses():
    """(p, c) on invariants, composed by stress_tensor, equal stability.rheologies' 1-D (p, tau_xz, tau_zz)."""
    from stability import rheologies
    for name in ("mui", "icidr"):
        sig = plane.stress_tensor(name).subs({plane.ux: 0, plane.wx: 0})
        p, txz, tzz = rheologies.stress(name)
        assert sp.simplify(sig[0, 1] - txz) == 0
        assert sp.simplify(sig[1, 1] - (tzz - p)) == 0
        assert sp.simplify(sig[0, 0] - (-tzz - p)) == 0


def test_bad_law_names():
    with pytest.raises(ValueError, match="rheology"):
        plane.toolkit_law("newtonian")
    with pytest.raises(ValueError, match="rheology"):
        plane.resolve_law(3.0)
