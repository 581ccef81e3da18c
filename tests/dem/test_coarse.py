"""Coarse graining (appendix C) on synthetic particle data with known answers."""

import numpy as np
import pytest

from icidr_pde.dem import coarse


def test_uniform_rows_give_known_packing_fraction():
    # rows of disks (radius 0.3) every 0.5 in z, 10 per row over L = 10:
    # translation invariance => every bin holds (2/0.5) rows of area => phi = 10 pi r^2 / (L * 0.5)
    L, H, r = 10.0, 30.0, 0.3
    zs = np.arange(0.1, H, 0.5)
    x, z = np.meshgrid(np.arange(10) + 0.5, zs)
    x, z = x.ravel(), z.ravel()
    rad = np.full(z.size, r)
    zc, phi, u, w = coarse.profiles(z, np.zeros_like(z), np.zeros_like(z), rad, np.ones_like(z), L, H, 2.0)
    assert zc.size == 15
    np.testing.assert_allclose(phi, 10 * np.pi * r**2 / (L * 0.5), rtol=1e-12)


def test_disk_on_bin_edge_splits_in_half_and_wraps_periodically():
    H, L = 30.0, 4.0
    for z0, (b1, b2) in ((2.0, (0, 1)), (0.0, (14, 0))):
        A = coarse.slab_areas(np.array([z0]), np.array([0.5]), coarse.bin_edges(H, 2.0), H)[0]
        assert A.sum() == pytest.approx(np.pi * 0.25, rel=1e-12)
        assert A[b1] == pytest.approx(np.pi * 0.125, rel=1e-12)
        assert A[b2] == pytest.approx(np.pi * 0.125, rel=1e-12)


def test_known_velocities_give_bin_means():
    H, L = 30.0, 5.0
    rng = np.random.default_rng(1)
    b = rng.integers(0, 15, 400)
    z = 2.0 * b + 1.0 + rng.uniform(-0.4, 0.4, b.size)  # disks of r = 0.5 stay inside their bin
    rad = np.full(b.size, 0.5)
    mass = rng.uniform(0.5, 1.5, b.size)
    u_true, w_true = 0.1 * np.arange(15), -0.05 * np.arange(15) ** 2
    _, _, u, w = coarse.profiles(z, u_true[b], w_true[b], rad, mass, L, H, 2.0)
    present = np.isin(np.arange(15), b)
    np.testing.assert_allclose(u[present], u_true[present], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(w[present], w_true[present], rtol=1e-12, atol=1e-14)


def test_C1_two_particle_contact_by_hand():
    # two disks of radius 0.5 at distance 0.9 along x, inside bin 2 (z in [4, 6)),
    # Hookean contact f = k delta n on particle 1 (repulsive), delta = 0.1
    k, L, H, h = 1e4, 3.0, 30.0, 2.0
    r12 = np.array([-0.9, 0.0])         # r_1 - r_2
    f12 = k * 0.1 * r12 / 0.9           # force on 1 from 2
    W = 0.5 * np.array([r12[0] * f12[0], r12[1] * f12[1], r12[0] * f12[1]])  # each particle: half
    z = np.array([5.0, 5.0])
    P = coarse.stress_profile(z, np.array([5 / 30, 5 / 30]), np.zeros(2), np.ones(2),
                              np.stack([W, W]), L, H, V0=1.0, bin_height=h, offset=0.0)
    expected_xx = k * 0.1 * 0.9 / (h * L)  # |r| |f| / area
    assert P[2, 0] == pytest.approx(expected_xx, rel=1e-12)
    assert np.all(P[np.arange(15) != 2] == 0) and P[2, 1] == 0 and P[2, 2] == 0
    p, tau, mu = coarse.invariants(P[2])
    # uniaxial compression: p = ||tau|| = P_xx / 2, so mu = 1
    assert p == pytest.approx(expected_xx / 2) and mu == pytest.approx(1.0)


def test_C1_kinetic_part_about_affine_profile():
    # two particles at z = 15 moving +-0.2 about the affine profile V0 z/H = 0.5
    L, H = 3.0, 30.0
    z = np.array([15.5, 15.5])
    u = np.array([0.5 + 0.2, 0.5 - 0.2]) + 15.5 / 30 - 0.5
    P = coarse.stress_profile(z, u, np.zeros(2), np.array([2.0, 2.0]), np.zeros((2, 3)), L, H, 1.0,
                              offset=0.0)
    assert P[7, 0] == pytest.approx(2 * 2.0 * 0.04 / (2 * L))
    assert P[7, 1] == 0 and P[7, 2] == pytest.approx(0.0)


def test_invariants_of_simple_shear_stress():
    # pure shear stress P_xz = -s, P_xx = P_zz = p: mu = s/p
    p, tau, mu = coarse.invariants(np.array([2.0, 2.0, -0.6]))
    assert (p, tau, mu) == pytest.approx((2.0, 0.6, 0.3))


def test_inertial_number_definition_and_errors():
    # (2.9) with ||S|| = gamma/2: I = gamma d / sqrt(p/rho)
    assert coarse.inertial_number(0.1, 4.0) == pytest.approx(0.05)
    with pytest.raises(ValueError, match="p"):
        coarse.inertial_number(0.1, 0.0)
    with pytest.raises(ValueError, match="bin_height"):
        coarse.bin_edges(30.0, 7.0)
    with pytest.raises(ValueError, match="L"):
        coarse.profiles([1.0], [0.0], [0.0], [0.5], [1.0], 0.0, 30.0)


def test_lees_edwards_image_carries_shifted_velocity():
    # a disk centred on z = 0 is half in the bottom bin and half (its image at z = H)
    # in the top bin, where Lees-Edwards makes it move at u + V0
    H, L, V0 = 30.0, 4.0, 1.0
    _, phi, u, w = coarse.profiles([0.0], [0.1], [0.3], [0.5], [1.0], L, H, 2.0, V0=V0)
    assert u[0] == pytest.approx(0.1) and u[-1] == pytest.approx(0.1 + V0)
    assert w[0] == pytest.approx(0.3) and w[-1] == pytest.approx(0.3)
