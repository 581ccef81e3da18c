"""Appendix B: (B1)-(B15) and the numerical convexity of psi."""

import numpy as np

from stability import dissipation


def test_appendix_B_statuses(all_checks):
    rows = [c for c in all_checks if c.section == dissipation.SECTION]
    got = {c.equation: c.status for c in rows}
    for eq in ("(B1)", "(B2)", "(B3)", "(B4)", "(B5)", "(B6)", "(B9a)/(B10)", "(B9b)/(B11)", "(B13)", "(B14)",
               "(B15)"):
        assert got[eq] == "exact", eq
    for eq in ("(B7)/(B12)", "(B15) sigma = dpsi/dD", "(B15) convexity"):
        assert got[eq] == "numeric", eq


def test_convexity_sample_independent_material():
    from icidr_pde.rheology import Material

    res = dissipation.convexity_sample(n=100, seed=11, material=Material(mu_s=0.3, mu_d=0.9))
    assert res["ok"] and res["min_ratio"] > 0


def test_psi_hessian_is_phi_gamma_in_shear_cell():
    """Hessian of psi(D) restricted to D = [[0, u_z/2], [u_z/2, w_z]] equals phi Gamma (numpy)."""
    import sympy as sp
    from stability.numeric import coefficients, gamma
    from stability.mui import M_numeric
    from stability.symbols import M, Psi, uz, wz

    psi, _, _, _ = dissipation.psi_of_D()
    A_, B_, C_ = dissipation.A_, dissipation.B_, dissipation.C_
    psi_sc = psi.subs({A_: 0, B_: uz / 2, C_: wz})
    H = sp.lambdify((uz, wz, M, Psi), sp.hessian(psi_sc, (uz, wz)), "numpy")
    for ph, u, w in [(0.78, 1 / 30, 0.05), (0.7, -0.3, -0.2), (0.8, 0.01, 1.0)]:
        Hn = np.asarray(H(u, w, float(M_numeric(ph)), (0.817 - ph) / 0.314), float)
        assert np.allclose(Hn / ph, gamma(coefficients("icidr", ph, u, w)), rtol=1e-10)
