"""General 1-D linearisation of the shear-cell equations (appendix A, (A1)-(A9)).

For any rheology given as sympy expressions p, tau_xz, tau_zz of (phi, u_z, w_z), the
momentum equations (3.2)-(3.3), divided by rho_* phi, are
``u_t = d_z F1 / (rho_* phi)``, ``w_t = d_z F2 / (rho_* phi)`` with fluxes
``F1 = tau_xz``, ``F2 = tau_zz - p``.  Freezing the base state, the principal part is
(A2) with

    a_i = dF_i/dphi / (rho_* phi),    b_ij = dF_i/d(u_z, w_z)_j / (rho_* phi),

so no coefficient is typed in: they are derivatives of the fluxes.  From these:
A(xi) (A4), Gamma (A5), the characteristic polynomial (A6) with A, B, C (A7), the
large-xi balance (A8), its roots (A9) and the limit -C/B of the third eigenvalue.
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from .checks import EXACT, FAILS, Check, exact_zero
from .symbols import Lam, lam, phi, rho, uz, w0, wz, xi

SECTION = "A general"

# generic coefficient symbols of (A2)
a1, a2, b11, b12, b21, b22 = sp.symbols("a1 a2 b11 b12 b21 b22", real=True)
GENERIC = {"a1": a1, "a2": a2, "b11": b11, "b12": b12, "b21": b21, "b22": b22}


def principal_coefficients(p, tau_xz, tau_zz):
    """Coefficients a1, a2, b11, b12, b21, b22 of (A2), by differentiating the fluxes."""
    F1, F2 = tau_xz, tau_zz - p
    den = rho * phi
    return {
        "a1": sp.diff(F1, phi) / den, "b11": sp.diff(F1, uz) / den, "b12": sp.diff(F1, wz) / den,
        "a2": sp.diff(F2, phi) / den, "b21": sp.diff(F2, uz) / den, "b22": sp.diff(F2, wz) / den,
    }


def operator_A2(c=None, base_w=w0):
    """The linear operator (A2) acting on a perturbation vector of functions of z."""
    c = GENERIC if c is None else c
    z = sp.Symbol("z", real=True)

    def apply(vec):
        ph, u, w = vec
        Dz = lambda f: sp.diff(f, z)  # noqa: E731
        return sp.Matrix([
            -base_w * Dz(ph) - phi * Dz(w),
            c["a1"] * Dz(ph) + c["b11"] * Dz(Dz(u)) - base_w * Dz(u) + c["b12"] * Dz(Dz(w)),
            c["a2"] * Dz(ph) + c["b21"] * Dz(Dz(u)) + c["b22"] * Dz(Dz(w)) - base_w * Dz(w),
        ])

    return apply, z


def symbol_matrix(c=None, base_w=0):
    """A(xi) of (A4), obtained by applying (A2) to the normal mode (A3) e^{i xi z}."""
    apply, z = operator_A2(c, base_w)
    e = sp.exp(sp.I * xi * z)
    cols = []
    for k in range(3):
        v = [0, 0, 0]
        v[k] = e
        cols.append(sp.simplify(apply(v) / e))
    return sp.Matrix.hstack(*cols)


def gamma_matrix(c=None):
    """Gamma of (A5): the matrix multiplying -xi^2 in the lower right block of A(xi)."""
    c = GENERIC if c is None else c
    return sp.Matrix([[c["b11"], c["b12"]], [c["b21"], c["b22"]]])


def char_poly_coefficients(c=None):
    """A, B, C of (A6): det(A(xi) - lambda I) = -(lambda^3 + A lambda^2 + B lambda + C)."""
    Amat = symbol_matrix(c)
    cp = sp.expand(-(Amat - lam * sp.eye(3)).det())
    poly = sp.Poly(cp, lam)
    coeffs = poly.all_coeffs()
    assert coeffs[0] == 1
    return tuple(sp.expand(x) for x in coeffs[1:])


def large_xi_leading(c=None):
    """Coefficient of xi^6 after lambda = Lambda xi^2 in lambda^3 + A lambda^2 + B lambda + C."""
    A, B, C = char_poly_coefficients(c)
    expr = sp.expand(lam**3 + A * lam**2 + B * lam + C).subs(lam, Lam * xi**2)
    return sp.Poly(sp.expand(expr), xi).coeff_monomial(xi**6)


def roots_A9(c=None):
    """(Lambda_+, Lambda_-) of (A9) for Gamma of the coefficients `c`."""
    G = gamma_matrix(c)
    tr, det = G.trace(), G.det()
    disc = sp.sqrt(tr**2 - 4 * det)
    return (-tr + disc) / 2, (-tr - disc) / 2


def third_eigenvalue_limit(c=None):
    """lim_{xi -> oo} -C/B, the limit of the bounded third eigenvalue lambda_0 of A(xi)."""
    A, B, C = char_poly_coefficients(c)
    return sp.simplify(sp.limit(-C / B, xi, sp.oo))


@lru_cache(maxsize=None)
def generic_results():
    """Cached generic (symbolic-coefficient) A(xi), Gamma, (A, B, C) and -C/B limit."""
    A, B, C = char_poly_coefficients()
    return {"A": symbol_matrix(), "Gamma": gamma_matrix(), "ABC": (A, B, C),
            "limit": third_eigenvalue_limit()}


def checks() -> list[Check]:
    """Rheology-independent checks of (A4)-(A9)."""
    sec = SECTION
    out = []
    res = generic_results()
    Amat, G = res["A"], res["Gamma"]
    printedA4 = sp.Matrix([[0, 0, -sp.I * phi * xi],
                           [sp.I * a1 * xi, -b11 * xi**2, -b12 * xi**2],
                           [sp.I * a2 * xi, -b21 * xi**2, -b22 * xi**2]])
    ok = all(exact_zero(x) for x in (Amat - printedA4))
    out.append(Check("(A4)", "normal modes (A3) of (A2) give lambda = eig A(xi), w0 = 0", EXACT if ok else FAILS,
                     "A(xi) derived by applying (A2) to e^{i xi z}", section=sec))
    Aw = symbol_matrix(base_w=w0)
    okw = all(exact_zero(x) for x in (Aw - Amat + sp.I * w0 * xi * sp.eye(3)))
    out.append(Check("(A4) w0", "w0 only adds -i w0 xi to the diagonal: eigenvalues shift by an imaginary amount",
                     EXACT if okw else FAILS, "A_w0(xi) - A_0(xi) = -i w0 xi Id", section=sec))
    okG = all(exact_zero(x) for x in (Amat[1:, 1:] + xi**2 * G))
    out.append(Check("(A5)", "Gamma = [[b11, b12], [b21, b22]] multiplies -xi^2 in A(xi)", EXACT if okG else FAILS,
                     "", section=sec))
    A, B, C = res["ABC"]
    trG, detG = G.trace(), G.det()
    okA = exact_zero(A - trG * xi**2)
    Brem = sp.expand(B - detG * xi**4)
    okB = sp.Poly(Brem, xi).degree() <= 3
    okC = sp.Poly(C, xi).degree() <= 4
    out.append(Check("(A6)-(A7)", "A = tr(Gamma) xi^2 + O(xi), B = det(Gamma) xi^4 + O(xi^3), C = O(xi^4)",
                     EXACT if okA and okB and okC else FAILS,
                     f"A = {sp.sstr(sp.factor(A))}; B - det(Gamma) xi^4 = {sp.sstr(sp.factor(Brem))}; "
                     f"C = {sp.sstr(sp.factor(C))}", section=sec))
    # with w0 != 0 the polynomial is the w0 = 0 one at lambda + i w0 xi: C picks up det(Gamma) xi^4 (i w0 xi)
    Aw_, Bw_, Cw_ = (sp.expand(x) for x in sp.Poly(sp.expand(-(Aw - lam * sp.eye(3)).det()), lam).all_coeffs()[1:])
    shift = sp.expand((lam + sp.I * w0 * xi) ** 3 + A * (lam + sp.I * w0 * xi) ** 2 + B * (lam + sp.I * w0 * xi) + C)
    okshift = exact_zero(sp.expand(lam**3 + Aw_ * lam**2 + Bw_ * lam + Cw_) - shift)
    degC = sp.Poly(Cw_, xi).degree()
    out.append(Check("(A7) w0", "(A7) needs w0 = 0 (as the paper sets): with w0 != 0 the polynomial is shifted, "
                     "lambda -> lambda + i w0 xi, and C = O(xi^5)", EXACT if okshift and degC == 5 else FAILS,
                     f"char. poly(w0) = char. poly(0) at lambda + i w0 xi; deg_xi C(w0) = {degC}; the shift is "
                     "imaginary so Re(lambda) and the well-posedness verdict are unchanged", section=sec))
    lead = large_xi_leading()
    ok8 = exact_zero(lead - Lam * (Lam**2 + trG * Lam + detG))
    out.append(Check("(A8)", "xi^6 balance: Lambda^3 + tr(Gamma) Lambda^2 + det(Gamma) Lambda = 0",
                     EXACT if ok8 else FAILS, "coefficient of xi^6 after lambda = Lambda xi^2", section=sec))
    lp, lm = roots_A9()
    ok9 = exact_zero(lp + lm + trG) and exact_zero(sp.expand(lp * lm) - detG)
    out.append(Check("(A9)", "Lambda_pm = (-tr Gamma pm sqrt(tr^2 - 4 det))/2 are the roots of (A8)",
                     EXACT if ok9 else FAILS, "Vieta: sum = -tr Gamma, product = det Gamma", section=sec))
    lim = res["limit"]
    target = phi * (a2 * b11 - a1 * b21) / detG
    okl = exact_zero(lim - target)
    out.append(Check("(A17) -C/B", "third eigenvalue lambda_0 -> -C/B = phi (a2 b11 - a1 b21)/det(Gamma) (finite if "
                     "det Gamma != 0)", EXACT if okl else FAILS, f"-C/B -> {sp.sstr(lim)}", section=sec))
    return out
