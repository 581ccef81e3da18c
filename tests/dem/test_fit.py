"""Fits of (2.10), (2.11) recover known parameters from synthetic data."""

import numpy as np
import pytest

from icidr_pde.dem.fit import fit_mu, fit_phi, mu_of_I

T1 = {"mu_s": 0.248, "mu_d": 0.588, "I0": 0.145, "phi_c": 0.817, "a": 0.314}


def test_mu_of_I_limits():
    assert mu_of_I(1e-12, 0.2, 0.6, 0.1) == pytest.approx(0.2)
    assert mu_of_I(1e12, 0.2, 0.6, 0.1) == pytest.approx(0.6)
    assert mu_of_I(0.1, 0.2, 0.6, 0.1) == pytest.approx(0.4)  # I = I0: midpoint


def test_fit_mu_recovers_parameters_within_uncertainty():
    rng = np.random.default_rng(3)
    I = np.linspace(0.02, 0.6, 12)
    sd = 0.004
    mu = mu_of_I(I, T1["mu_s"], T1["mu_d"], T1["I0"]) + rng.normal(0, sd, I.size)
    fit, std = fit_mu(I, mu, np.full(I.size, sd), 1)
    for k in ("mu_s", "mu_d", "I0"):
        assert abs(fit[k] - T1[k]) < 4 * std[k]
        assert std[k] < 0.2 * T1[k]


def test_fit_phi_exact_line():
    phi = np.array([0.76, 0.77, 0.78, 0.79, 0.80])
    I = (T1["phi_c"] - phi) / T1["a"]
    fit, std = fit_phi(I, phi)
    assert fit["phi_c"] == pytest.approx(T1["phi_c"], rel=1e-10)
    assert fit["a"] == pytest.approx(T1["a"], rel=1e-10)


def test_fit_rejects_too_few_points():
    with pytest.raises(ValueError, match="I"):
        fit_mu([0.1, 0.2], [0.3, 0.4])
