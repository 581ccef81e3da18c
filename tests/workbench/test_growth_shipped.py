"""Measured growth of single Fourier modes (time integration of the linearised equations) against the
symbol, for the shipped laws not covered by the non-monotonic tests: saturating Phi(I), blended pressure."""

import numpy as np
import pytest

from icidr_pde.rheology import get_rheology
from stability import workbench as wb


@pytest.mark.parametrize("name, state", [("icidr-saturating-phi", (0.78, 1 / 30, 0.05)),
                                         ("mui-saturating-phi", (0.78, 1 / 30, 0.05)),
                                         pytest.param("icidr-blended", (0.815, 1 / 30, 0.01), marks=pytest.mark.slow),
                                         pytest.param("icidr-blended-quarter", (0.815, 1 / 30, 0.01),
                                                      marks=pytest.mark.slow)])
def test_measured_growth_is_the_symbol(name, state):
    """measured rate = max Re eig A(xi) (sympy toolkit); its xi -> oo sign = the kernel symbol's Lambda_+."""
    from stability.growth import measured_growth_rate

    r = get_rheology(name)
    g = measured_growth_rate(name, *state, xi=30.0, material=r.material)
    assert g["rel_error"] < 1e-6, g
    phi, uz, wz = (np.array([v]) for v in state)
    lp, _ = wb._eig_minus_gamma(wb.one_d_gamma(r, phi, uz, wz))
    if "mui" in name:                                          # chi > 0 here: Lambda_+ > 0, growth ~ xi^2
        assert lp[0].real > 0 and g["measured"] / 30.0**2 == pytest.approx(lp[0].real, rel=0.05)
    else:                                                      # well-posed state: bounded growth
        assert lp[0].real < 0 and g["measured"] < 30.0**2 * 0.05 * abs(lp[0].real)
