"""Appendix-C parameters: independent checks (restitution, packing fraction, time step)."""

import math

import numpy as np
import pytest

from icidr_pde.dem.params import DIAMETER_CLASSES, DEMParams


def test_restitution_of_unit_disks_is_paper_value():
    # appendix C: eta_n = 4.2 "so that the particles have a restitution coefficient e = 0.9"
    # damped oscillator of two unit disks (m = pi/4 each) with k = 1e4
    m_eff = (math.pi / 4) / 2
    beta, w0 = 4.2 / (2 * m_eff), math.sqrt(1e4 / m_eff)
    e = math.exp(-math.pi * beta / math.sqrt(w0**2 - beta**2))
    assert DEMParams().restitution() == pytest.approx(e, rel=1e-12)
    assert e == pytest.approx(0.9, abs=0.01)


def test_box_length_gives_requested_packing_fraction():
    p = DEMParams(n_particles=1000)
    d = p.diameters(np.random.default_rng(0))
    assert sorted(set(d)) == list(DIAMETER_CLASSES)
    assert all(np.sum(d == c) == 200 for c in DIAMETER_CLASSES)
    for phi0 in (0.76, 0.8):
        L = p.box_length(phi0)
        assert np.sum(np.pi * d**2 / 4) / (L * p.H) == pytest.approx(phi0, rel=1e-12)


def test_time_step_is_small_fraction_of_contact_time():
    p = DEMParams()
    # shortest contact: two 0.8 d disks, mass pi 0.16 each
    m_eff = math.pi * 0.16 / 2
    tc = math.pi / math.sqrt(1e4 / m_eff - (4.2 / (2 * m_eff)) ** 2)
    assert p.dt == pytest.approx(tc / 50, rel=1e-12)


@pytest.mark.parametrize("kw, name", [
    ({"n_particles": 12}, "n_particles"), ({"H": 1.0}, "H"), ({"k_n": -1.0}, "k_n"),
    ({"mu_p": -0.1}, "mu_p"), ({"dt_fraction": 0.5}, "dt_fraction"),
    ({"bin_height": 7.0}, "bin_height"),
])
def test_bad_parameters_raise_naming_parameter(kw, name):
    with pytest.raises(ValueError, match=name):
        DEMParams(**kw)


def test_bad_phi0_raises():
    with pytest.raises(ValueError, match="phi0"):
        DEMParams().box_length(0.9)
