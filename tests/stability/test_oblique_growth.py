"""Measured growth of single oblique plane waves (linearised 2-D system) against the symbol."""

import numpy as np
import pytest

from stability import directional as D
from stability import oblique_growth as og

STEADY = (0.0, 1.0 / 30.0, 0.0, 0.0)


@pytest.mark.parametrize("name, angle, xi", [("mui", 45.0, 3.0), ("mui", 30.0, 30.0), ("mui", 120.0, 10.0),
                                             ("mui", 90.0, 10.0), ("icidr", 45.0, 3.0), ("icidr", 60.0, 10.0),
                                             ("icidr", 0.0, 30.0)])
def test_measured_growth_matches_max_re_eig(name, angle, xi):
    g = og.measured_growth_rate(name, 0.78, STEADY, xi, angle)
    assert g["rel_error"] <= 1e-6, g


def test_measured_growth_follows_lambda_max_theta():
    """mu(I) at steady shear: inside the ill-posed interval measured rate / xi^2 -> Lambda_max(theta) > 0 (O(1/xi));
    outside it the O(xi^2) roots decay and the measured rate tends to the bounded third root phi n.Gamma^-1 alpha."""
    r = D.directional_stability("mui", 0.78, STEADY, angles_deg=[20.0, 45.0, 70.0, 100.0, 160.0])
    lam0 = r.lambda0_limit
    for k, (angle, lam) in enumerate(zip(r.angles_deg, r.lambda_max)):
        rates = [og.measured_growth_rate("mui", 0.78, STEADY, xi, angle)["measured"] for xi in (10.0, 100.0)]
        if lam > 0:
            errs = [abs(g / xi**2 - lam) for g, xi in zip(rates, (10.0, 100.0))]
            assert errs[1] < 0.2 * errs[0] and errs[1] < 2e-2 * lam
        else:
            errs = [abs(g - lam0[k]) for g in rates]
            assert errs[1] < 0.05 * errs[0] + 1e-9 and errs[1] < 1e-3 * abs(lam0[k])


def test_oblique_state_with_full_gradient():
    """A general gradient (compression, rotation): both rheologies, an angle off the axes."""
    L = (-0.02, 0.05, 0.01, -0.01)
    for name in ("mui", "icidr"):
        g = og.measured_growth_rate(name, 0.75, L, 8.0, 65.0)
        assert g["rel_error"] <= 1e-6, g


def test_complex_step_operator_acts_on_the_wave_only():
    box = og.PlaneWaveBox(5.0, 30.0)
    J = og.linear_operator("mui", 0.78, STEADY, box)
    # a field without the wave (a constant) is in the kernel
    assert np.abs(J @ np.ones(J.shape[1])).max() < 1e-12 * np.abs(J).max()
    with pytest.raises(ValueError, match="xi"):
        og.measured_growth_rate("mui", 0.78, STEADY, -1.0, 30.0)
