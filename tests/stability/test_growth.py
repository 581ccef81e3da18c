"""Item 8: eigenvalues vs symbols, measured growth rates, FD-operator spectrum."""

import numpy as np
import pytest

from .conftest import ILL_POSED
from stability import growth
from stability.numeric import A_matrix, coefficients


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_eigenvalues_approach_lambda_xi2(name):
    rows, sn = growth.eigen_vs_symbol(name, ILL_POSED["phi"], ILL_POSED["uz"], ILL_POSED["wz"], [1e2, 1e3, 1e4])
    errs = [abs(r["lambda_plus"] - sn.lambda_plus) for r in rows]
    assert errs[-1] < 1e-5 * abs(sn.lambda_plus)
    assert errs[2] < errs[1] < errs[0] or errs[0] < 1e-12      # converges like 1/xi
    assert abs(rows[-1]["lambda_minus"] - sn.lambda_minus) < 1e-5 * abs(sn.lambda_minus)
    assert abs(rows[-1]["lambda0"] - sn.lambda0_limit) < 1e-5 * abs(sn.lambda0_limit)


@pytest.mark.parametrize("name", ["mui", "icidr"])
@pytest.mark.parametrize("xi", [3.0, 10.0, 30.0, 100.0])
def test_measured_growth_rate_matches_max_re_eig(name, xi):
    st = ILL_POSED
    g = growth.measured_growth_rate(name, st["phi"], st["uz"], st["wz"], xi)
    ev = np.linalg.eigvals(A_matrix(coefficients(name, st["phi"], st["uz"], st["wz"]), st["phi"], xi))
    assert g["predicted"] == ev.real.max()
    assert abs(g["measured"] - ev.real.max()) <= 1e-6 * abs(ev.real.max())


def test_measured_growth_rate_well_posed_mui_state():
    """A well-posed mu(I) state (chi < 0): decay rates are measured too."""
    g = growth.measured_growth_rate("mui", 0.7, 0.3, -0.1, 10.0)
    assert g["rel_error"] <= 1e-6


def _match(a, b):
    """max over a of the distance to the nearest element of b (relative to max |b|)."""
    return max(np.min(np.abs(b - x)) for x in a) / np.abs(b).max()


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_fd_jacobian_spectrum_equals_discrete_symbol(name):
    st = ILL_POSED
    J = growth.fd_jacobian(name, st["phi"], st["uz"], st["wz"], 48)
    ev = np.linalg.eigvals(J)
    sym = growth.fd_symbol_eigenvalues(name, st["phi"], st["uz"], st["wz"], 48)
    assert _match(ev, sym) < 1e-8 and _match(sym, ev) < 1e-8
    # complex-step Jacobian agrees with a plain finite-difference Jacobian column
    h = 30.0 / 48
    U0 = np.concatenate([np.full(48, st["phi"]), np.zeros(96)])
    e = np.zeros(144)
    e[50] = 1e-7
    col = (growth.fd_rhs(name, U0 + e, st["uz"], st["wz"], h) - growth.fd_rhs(name, U0 - e, st["uz"], st["wz"], h)) / 2e-7
    assert np.allclose(col, J[:, 50], rtol=1e-5, atol=1e-6 * np.abs(J[:, 50]).max())


def test_fd_growth_mui_like_inverse_h2_icidr_bounded():
    st = ILL_POSED
    Ns = (32, 64, 128)
    mu = np.array([growth.fd_max_growth("mui", st["phi"], st["uz"], st["wz"], N) for N in Ns])
    ic = np.array([growth.fd_max_growth("icidr", st["phi"], st["uz"], st["wz"], N) for N in Ns])
    h = 30.0 / np.array(Ns)
    # mu(I): growth * h^2 -> 4 Lambda_+ (symbol at k h = pi), so it doubles-squared per halving
    from stability.numeric import stability_numbers

    lp = stability_numbers("mui", **st).lambda_plus.real
    assert np.allclose(mu * h**2, 4 * lp, rtol=0.02)
    assert np.all(np.abs(mu[1:] / mu[:-1] - 4) < 0.05)
    # iCIDR: bounded by the continuum bound sup_xi max Re eig A(xi) <= -C/B limit (+ margin)
    lim = stability_numbers("icidr", st["phi"], st["uz"], st["wz"]).lambda0_limit
    assert np.all(ic < 1.05 * lim) and np.all(ic > 0)
    # finer grids (exact discrete symbol): still bounded while mu(I) keeps growing like 1/h^2
    big = [growth.fd_max_growth("icidr", st["phi"], st["uz"], st["wz"], N, dense=False) for N in (1024, 4096)]
    assert max(big) < 1.05 * lim


def test_fd_rejects_bad_grid():
    with pytest.raises(ValueError, match="N"):
        growth.fd_jacobian("mui", 0.78, 0.1, 0.1, 2)
    with pytest.raises(ValueError, match="phi"):
        growth.fd_jacobian("mui", 0.95, 0.1, 0.1, 16)


def test_plot_fd_growth(tmp_path):
    path, rows = growth.plot_fd_growth(str(tmp_path / "g.png"), Ns=(16, 32, 64))
    assert (tmp_path / "g.png").stat().st_size > 1000
    assert rows[-1]["mui"] > rows[0]["mui"] * 10
