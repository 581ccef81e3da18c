"""General linearisation (A2)-(A9): symbolic statements and numpy cross-checks."""

import numpy as np
import sympy as sp

from stability import linearize as L
from stability.numeric import A_matrix
from stability.symbols import phi, xi


def test_generic_checks_exact():
    for c in L.checks():
        assert c.status == "exact", (c.equation, c.detail)


def test_A_matrix_matches_numpy_builder_and_char_poly():
    rng = np.random.default_rng(1)
    res = L.generic_results()
    A_sym = sp.lambdify((phi, xi, *L.GENERIC.values()), res["A"], "numpy")
    Ab, Bb, Cb = res["ABC"]
    coef = sp.lambdify((phi, xi, *L.GENERIC.values()), [Ab, Bb, Cb], "numpy")
    for _ in range(5):
        vals = dict(zip(L.GENERIC, rng.normal(size=6)))
        ph, x = rng.uniform(0.5, 0.8), rng.uniform(1, 20)
        A_np = A_matrix(vals, ph, x)
        assert np.allclose(np.asarray(A_sym(ph, x, *vals.values()), complex), A_np, rtol=1e-13)
        # numpy's characteristic polynomial (independent): det(lambda I - A) = lambda^3 + A lambda^2 + ...
        assert np.allclose(np.poly(A_np)[1:], coef(ph, x, *vals.values()), rtol=1e-9, atol=1e-9)


def test_third_eigenvalue_limit_numerically():
    rng = np.random.default_rng(2)
    lim = sp.lambdify((phi, *L.GENERIC.values()), L.generic_results()["limit"], "numpy")
    for _ in range(5):
        G = rng.normal(size=(2, 2))
        G = G @ G.T + np.eye(2)               # well-posed Gamma (positive definite)
        vals = {"a1": rng.normal(), "a2": rng.normal(), "b11": G[0, 0], "b12": G[0, 1], "b21": G[1, 0],
                "b22": G[1, 1]}
        ph = 0.7
        ev = np.linalg.eigvals(A_matrix(vals, ph, 1e5))
        lam0 = ev[np.argmin(np.abs(ev))]
        assert abs(lam0 - lim(ph, *vals.values())) < 1e-6 * max(1, abs(lam0))
