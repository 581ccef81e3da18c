"""Imposition of (5.7), additive fine-bin records and their post-processing (no LAMMPS)."""

import numpy as np
import pytest

from icidr_pde.dem import analysis as A
from icidr_pde.dem import coarse
from icidr_pde.dem import ensemble as E
from icidr_pde.dem.driver import Snapshot
from icidr_pde.dem.params import DEMParams

H, L, V0 = 30.0, 20.0, 1.0


def _snapshot(n=3000, seed=0, sigma=0.05):
    rng = np.random.default_rng(seed)
    z = rng.uniform(0, H, n)
    r = rng.choice([0.4, 0.5, 0.6], n)
    m = np.pi * r**2
    u = V0 * z / H + rng.normal(0, sigma, n)
    w = rng.normal(0, sigma, n)
    return Snapshot(t=0.0, x=rng.uniform(0, L, n), z=z, u=u, w=w, radius=r, mass=m,
                    virial=np.zeros((n, 3)), L=L, H=H)


def test_strain_rate_ratio_is_2S_of_57_by_finite_differences():
    p = E.Perturbation()
    z = np.linspace(0.5, 29.5, 59)
    h = 1e-6
    u1, w1 = p.velocities(z + h, H, V0)
    u0, w0 = p.velocities(z - h, H, V0)
    uz, wz = (u1 - u0) / (2 * h), (w1 - w0) / (2 * h)
    # deviatoric S (2.5) of the 1-D field: [[-w_z/2, u_z/2], [u_z/2, w_z/2]], ||S||^2 = tr(S^2)/2
    S = np.stack([[-wz / 2, uz / 2], [uz / 2, wz / 2]])
    norm = np.sqrt(np.einsum("ijk,jik->k", S, S) / 2)
    np.testing.assert_allclose(p.strain_rate_ratio(z, H), 2 * norm * H / V0, rtol=1e-6)


@pytest.mark.parametrize("mode", ["keep", "drop", "local"])
def test_impose_gives_57_mean_and_the_chosen_fluctuations(mode):
    s = _snapshot()
    p = E.Perturbation(fluctuations=mode)
    vx, vz = E.impose(s, p, DEMParams(H=H))
    u57, w57 = p.velocities(s.z, H, V0)
    edges = coarse.bin_edges(H, 2.0)
    idx = np.searchsorted(edges, s.z, side="right") - 1
    # fluctuation of the imposed state about (5.7) ...
    fu, fw = vx - u57, vz - w57
    # ... has zero mass-weighted mean in every 2 d bin (for 'local' only approximately:
    # the scale varies inside a bin)
    mb = np.bincount(idx, s.mass)
    tol = 1e-12 if mode != "local" else 0.1 * 0.05
    np.testing.assert_allclose(np.bincount(idx, s.mass * fu) / mb, 0, atol=tol)
    np.testing.assert_allclose(np.bincount(idx, s.mass * fw) / mb, 0, atol=tol)
    # ... and is the particle's own fluctuation about its bin mean, scaled as chosen
    du = s.u - V0 * s.z / H
    own_u = du - (np.bincount(idx, s.mass * du) / mb)[idx]
    scale = {"keep": 1.0, "drop": 0.0, "local": p.strain_rate_ratio(s.z, H)}[mode]
    np.testing.assert_allclose(fu, scale * own_u, atol=1e-12)


def test_bad_perturbations_name_the_parameter():
    with pytest.raises(ValueError, match="fluctuations"):
        E.Perturbation(fluctuations="warm")
    with pytest.raises(ValueError, match="`a`"):
        E.Perturbation(a=1.5)
    with pytest.raises(ValueError, match="dt_fraction"):
        E.Perturbation(dt_fraction=0.5)
    with pytest.raises(ValueError, match="preparation"):
        E.BaseState(preparation="shake")


@pytest.mark.parametrize("definition", coarse.VELOCITY_DEFINITIONS)
def test_merging_fine_bins_equals_coarse_binning(definition):
    s = _snapshot(800)
    fine = coarse.layer_moments(s.z, s.u, s.w, s.radius, s.mass, L, H, 1.0, V0)
    coarse2 = coarse.layer_moments(s.z, s.u, s.w, s.radius, s.mass, L, H, 2.0, V0)
    for merged, direct in zip(coarse.fields_from_moments(fine, L, 1.0, definition, merge=2),
                              coarse.fields_from_moments(coarse2, L, 2.0, definition)):
        np.testing.assert_allclose(merged, direct, rtol=1e-12)


def test_slab_mass_velocity_is_the_mass_weighted_mean():
    # two disks well inside bin 2 (z in [4, 6)), radii 0.3 and 0.6, mass = pi r^2
    z = np.array([5.0, 5.0])
    r = np.array([0.3, 0.6])
    m = np.pi * r**2
    u = np.array([1.0, 0.0])
    _, _, ub, _ = coarse.profiles(z, u, np.zeros(2), r, m, L, H, 2.0, definition="slab_mass")
    assert ub[2] == pytest.approx(m[0] / m.sum(), rel=1e-12)
    _, _, ua, _ = coarse.profiles(z, u, np.zeros(2), r, m, L, H, 2.0, definition="area_times_mass")
    assert ua[2] == pytest.approx(m[0] ** 2 / (m**2).sum(), rel=1e-12)   # weights A m ~ r^4


def _result_from(snaps, hb=1.0):
    recs = [E.record(s, hb, V0) for s in snaps]
    out = {f"m_{k}": np.array([r[k] for r in recs]) for k in recs[0]}
    out.update(times=np.arange(len(snaps)) * 0.1, L=L, H=H, V0=V0, record_bin=hb, offset0=0.0)
    return out


def test_frames_of_u():
    s = _snapshot(4000, sigma=0.0)
    s.u = s.u + 0.05  # streaming offset
    r = _result_from([s])
    r["offset0"] = 0.05
    _, z, _, u_off, _ = E.fields(r, 2.0, frame="offset")
    _, _, _, u_lab, _ = E.fields(r, 2.0, frame="lab")
    np.testing.assert_allclose(u_lab[0] - u_off[0], 0.05, rtol=1e-12)
    # linear field: bin means lie on V0 z/H up to where the slab's mass centre sits (~1e-3 d)
    np.testing.assert_allclose(u_off[0], z / H, atol=5e-3)
    _, _, _, u_lay, _ = E.fields(r, 2.0, frame="layers")
    # the z = 0 layer, from the bottom and top bins (Lees-Edwards: u(H) = u(0) + V0), is at rest
    assert 0.5 * (u_lay[0, 0] + u_lay[0, -1] - V0) == pytest.approx(0.0, abs=1e-12)


def test_temperature_of_known_fluctuations():
    s = _snapshot(60000, sigma=0.05)
    T = E.temperature(_result_from([s]), bin_height=2.0)
    # <|dv|^2>/2 = (sigma^2 + sigma^2)/2, plus the spread of V0 z/H inside a centre bin: zero,
    # because u - V0 z/H is used (the affine part removed per particle)
    np.testing.assert_allclose(T[0], 0.05**2, rtol=0.08)


def test_dem_stress_sums_virial_and_kinetic_parts():
    s = _snapshot(2000, sigma=0.0)
    s.virial = np.tile([1.0, 2.0, -0.5], (s.z.size, 1))
    r = _result_from([s])
    P = A.dem_stress([r], 2.0)[0]
    counts = np.bincount(np.searchsorted(coarse.bin_edges(H, 2.0), s.z, side="right") - 1, minlength=15)
    np.testing.assert_allclose(P[:, 0], counts * 1.0 / (2 * L), rtol=1e-12)   # no fluctuations
    np.testing.assert_allclose(P[:, 2], counts * -0.5 / (2 * L), rtol=1e-12)


def test_strain_rates_and_local_I_of_steady_shear():
    z = np.arange(15) * 2.0 + 1.0
    u = np.tile(V0 * z / H, (3, 1))
    w = np.zeros_like(u)
    uz, wz = A.strain_rates(u, w, 2.0, V0)
    np.testing.assert_allclose(uz, V0 / H, rtol=1e-12)   # across z = 0 = H too (Lees-Edwards jump)
    np.testing.assert_allclose(wz, 0.0, atol=1e-15)
