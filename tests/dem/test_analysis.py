"""Peak statistics, bootstrap and error metrics of the audit on exact synthetic data."""

import numpy as np
import pytest

from icidr_pde.dem import analysis as A

H = 30.0
Z = np.arange(15) * 2.0 + 1.0


def test_mode_amplitude_recovers_an_exact_bin_averaged_sine():
    s = A.sine_basis(Z, H, 2.0)
    k = 2 * np.pi / H
    exact = (np.cos(k * (Z - 1)) - np.cos(k * (Z + 1))) / (2 * k)   # mean of sin over [z-1, z+1]
    np.testing.assert_allclose(s, exact, rtol=1e-12)
    assert A.mode_amplitude(0.037 * s, Z, H, 2.0) == pytest.approx(0.037, rel=1e-12)


def test_secondary_peak_and_decay_rate():
    t = np.linspace(0, 20, 201)
    series = np.exp(-6 * t) + 0.005 * t * np.exp(-0.25 * t)  # a hump after the first decay
    tp, hp = A.secondary_peak(t, series)
    # analytic maximum of 0.005 t e^{-t/4} (+ negligible e^{-6t}) is at t = 4
    assert tp == pytest.approx(4.0, abs=0.1)
    assert hp == pytest.approx(0.005 * 4 * np.exp(-1), rel=1e-3)
    assert A.decay_rate(t, 0.3 * np.exp(-0.2 * t)) == pytest.approx(0.2, rel=1e-10)


def test_bootstrap_standard_error_of_a_mean():
    rng = np.random.default_rng(3)
    x = rng.normal(0, 1, 40)
    bs = A.bootstrap(list(range(40)), lambda idx: {"m": float(x[idx].mean())}, n_boot=2000)
    value, se = bs["m"]
    assert value == pytest.approx(x.mean())
    assert se == pytest.approx(x.std(ddof=1) / np.sqrt(40), rel=0.1)


def test_relative_error_of_a_scaled_perturbation():
    """iCIDR = steady + 1.3 (DEM - steady) => error relative to the perturbation is 0.3."""
    t = np.linspace(0, 5, 11)[:, None]
    steady = {"phi": 0.78 + 0 * Z, "u": Z / H, "w": 0 * Z}
    pert = {"phi": 0.01 * np.cos(Z) * np.exp(-t), "u": 0.1 * np.sin(Z) * np.exp(-t),
            "w": 0.05 * np.sin(2 * Z) * np.exp(-t)}
    dem = {f: steady[f] + pert[f] for f in pert}
    cont = {f: steady[f] + 1.3 * pert[f] for f in pert}
    e = A.errors(dem, cont, 0.78, 1.0, H, Z)
    for f in ("phi", "u", "w"):
        assert e[f"R_{f}"] == pytest.approx(0.3, rel=1e-12)
    np.testing.assert_allclose(e["E_u"], 0.3 * np.sqrt(np.mean(pert["u"] ** 2, axis=1)), rtol=1e-12)
