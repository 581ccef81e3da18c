"""Chebyshev operators against independent truths: exact polynomial calculus,
Trefethen's printed matrices, Clenshaw-Curtis exactness, spectral convergence."""

import numpy as np
import pytest

from icidr_pde.cells.shear1d.cheb import cc_weights, cgl_nodes, cheb, clencurt, diff_matrix


def test_cheb_small_cases_match_trefethen():
    # Spectral Methods in MATLAB, ch. 6: N = 1 and N = 2 written out
    D1, x1 = cheb(1)
    np.testing.assert_allclose(x1, [1, -1], atol=1e-15)
    np.testing.assert_allclose(D1, [[0.5, -0.5], [0.5, -0.5]], atol=1e-15)
    D2, x2 = cheb(2)
    np.testing.assert_allclose(x2, [1, 0, -1], atol=1e-15)
    np.testing.assert_allclose(D2, [[1.5, -2, 0.5], [0.5, 0, -0.5], [-0.5, 2, -1.5]], atol=1e-14)


@pytest.mark.parametrize("N", [5, 12, 31, 64])
def test_D_differentiates_polynomials_exactly(N):
    H = 30.0
    z = cgl_nodes(N, H)
    D = diff_matrix(N, H)
    rng = np.random.default_rng(N)
    p = np.polynomial.Chebyshev(rng.normal(size=N), domain=[0, H])  # degree N - 1
    np.testing.assert_allclose(D @ p(z), p.deriv()(z), atol=1e-10 * np.max(np.abs(p.deriv()(z))) * N)
    np.testing.assert_allclose(D @ np.ones(N), 0, atol=1e-13)
    # degree N is no longer differentiated exactly
    q = np.polynomial.Chebyshev(np.eye(N + 1)[N], domain=[0, H])
    assert np.max(np.abs(D @ q(z) - q.deriv()(z))) > 1e-3


def test_nodes_are_cgl_points_with_exact_walls():
    N, H = 9, 30.0
    z = cgl_nodes(N, H)
    assert z[0] == 0.0 and z[-1] == H
    np.testing.assert_allclose(z, H / 2 * (1 - np.cos(np.pi * np.arange(N) / (N - 1))), atol=1e-13)
    np.testing.assert_allclose(z + z[::-1], H, atol=1e-13)  # symmetric about H/2
    assert np.all(np.diff(z) > 0)


@pytest.mark.parametrize("N", [4, 7, 20, 41])
def test_clenshaw_curtis_exact_to_degree_N_minus_1(N):
    H = 30.0
    z = cgl_nodes(N, H)
    c = cc_weights(N, H)
    assert np.all(c > 0)
    for k in range(N):
        exact = H ** (k + 1) / (k + 1)
        assert abs(c @ z**k - exact) <= 1e-12 * exact


def test_clencurt_matches_known_weights():
    # n = 2: Simpson's rule on [-1, 1]
    x, w = clencurt(2)
    np.testing.assert_allclose(w, [1 / 3, 4 / 3, 1 / 3], atol=1e-15)
    # n = 3: weights 1/9, 8/9, 8/9, 1/9
    _, w = clencurt(3)
    np.testing.assert_allclose(w, [1 / 9, 8 / 9, 8 / 9, 1 / 9], atol=1e-15)


def test_spectral_convergence_of_the_derivative():
    # f smooth (entire): the error of D f falls faster than any power of N
    H = 30.0
    errors = []
    for N in (11, 21, 31, 41):
        z = cgl_nodes(N, H)
        f = np.exp(np.sin(2 * np.pi * z / H))
        df = 2 * np.pi / H * np.cos(2 * np.pi * z / H) * f
        errors.append(np.max(np.abs(diff_matrix(N, H) @ f - df)))
    assert errors[-1] < 1e-9
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all(ratios > 30)  # each +10 points gains well over an order of magnitude


def test_invalid_sizes():
    with pytest.raises(ValueError):
        cheb(0)
    with pytest.raises(ValueError):
        clencurt(1.5)


def test_rhs_of_analytic_data_converges_exponentially():
    # the collocated right-hand side of iCIDR at the (entire) sine IC (5.7) converges
    # geometrically to that of a much finer grid: error ~ exp(-r N), r > 0.05
    from icidr_pde.cells.shear1d.cheb import ChebyshevShearCellPDE, interpolate
    from icidr_pde.scenes import get_scene

    pde = ChebyshevShearCellPDE("icidr")

    def rate(N):
        grid = pde.make_grid(N, 30.0)
        state = pde.make_state(grid, *get_scene("sine").initial_condition(pde.nodes(grid)))
        return pde.nodes(grid), pde.evolution_rate(state).data

    _, r_ref = rate(241)
    Ns = np.arange(17, 110, 12)
    err = []
    for N in Ns:
        z, r = rate(N)
        err.append(np.max(np.abs(r - interpolate(r_ref, z, 30.0))))
    slope = -np.polyfit(Ns, np.log(err), 1)[0]
    assert slope > 0.05
    assert err[-1] < 1e-4 * err[0]
