"""The symbol in three dimensions (stability.spatial) against truths computed without it.

The independent truth is the 3-D stress written here in plain numpy from the paper's laws,
(2.10), (2.13), (2.14) for mu(I),Phi(I) and (4.12), (4.14) for iCIDR, with the 3-D conventions
S = D - (div u/3) I, ||T|| = sqrt(tr T^2/2), sigma = -p I + c S, differentiated by central
differences: no sympy, no generated kernel.
"""

import json

import numpy as np
import pytest

from stability import directional, spatial

from .test_cli_directional import _run

MU_S, MU_D, I0, PHI_C, A = 0.248, 0.588, 0.145, 0.817, 0.314      # Table 1


def _M_Psi(phi):
    Psi = (PHI_C - phi) / A                                        # (2.13)
    return MU_S + (MU_D - MU_S) / (1 + I0 / Psi), Psi              # (2.10) at I = Psi(phi)


def _law(name, phi, div, s):
    """(p, c) with d = rho_* = 1: (2.14) with ||tau|| = mu p, or (4.12), (4.14)."""
    M, Psi = _M_Psi(phi)
    if name == "mui":
        p = (2 * s / Psi) ** 2
        return p, M * p / s
    G = np.sqrt(div**2 + M**2 * s**2) - div
    return (2 * G / (M * Psi)) ** 2, 4 * G / Psi**2


def _stress(name, phi, L):
    D = (L + L.T) / 2
    div = np.trace(D)
    S = D - div / 3 * np.eye(3)
    s = np.sqrt(np.sum(S * S) / 2)
    p, c = _law(name, phi, div, s)
    return -p * np.eye(3) + c * S


def _fd_principal_part(name, phi, L):
    """a_ij = d sigma_ij/d phi / phi, B_ijkl = d sigma_ij/d L_kl / phi by central differences (rho_* = 1)."""
    h = 1e-6 * np.abs(L).max()
    B = np.empty((3, 3, 3, 3))
    for k in range(3):
        for l in range(3):
            E = np.zeros((3, 3))
            E[k, l] = h
            B[:, :, k, l] = (_stress(name, phi, L + E) - _stress(name, phi, L - E)) / (2 * h * phi)
    hp = 1e-6
    a = (_stress(name, phi + hp, L) - _stress(name, phi - hp, L)) / (2 * hp * phi)
    return a, B


def _random_states(k, seed):
    rng = np.random.default_rng(seed)
    return [(float(rng.uniform(0.55, 0.8)), rng.normal(size=(3, 3)) * 10 ** rng.uniform(-2, 1)) for _ in range(k)]


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_gamma_is_the_finite_difference_of_the_plain_numpy_stress(name):
    """Gamma(n) and alpha(n) from sympy's derivatives equal those of the stress differenced in numpy, at random
    3x3 gradients (every mix of shear, dilation, rotation) and random directions."""
    rng = np.random.default_rng(7)
    for phi, L in _random_states(6, seed=3):
        a, B = spatial.principal_part_at(name, phi, L)
        a_fd, B_fd = _fd_principal_part(name, phi, L)
        n = rng.normal(size=(20, 3))
        n /= np.linalg.norm(n, axis=1)[:, None]
        G, al = spatial.gamma_alpha(a, B, n)
        G_fd, al_fd = spatial.gamma_alpha(a_fd, B_fd, n)
        assert np.allclose(G, G_fd, rtol=1e-6, atol=1e-6 * np.abs(G_fd).max())
        assert np.allclose(al, al_fd, rtol=1e-5, atol=1e-5 * np.abs(al_fd).max())
        assert np.allclose(spatial.stress_at(name, phi, L), _stress(name, phi, L), rtol=1e-12, atol=1e-12)


def test_icidr_is_well_posed_at_random_3d_states():
    """max over the sphere of max Re eig(-Gamma(n)) < 0, and the 4x4 symbol's eigenvalues over xi^2 at large xi
    are <= 0 up to the bounded phi root (Gamma from the numpy finite differences, not the module's)."""
    n = spatial.sphere_directions(300)
    for phi, L in _random_states(25, seed=11):
        r = spatial.spatial_stability("icidr", phi, L, directions=300)
        assert r.well_posed and r.max_lambda < 0 and r.ill_posed_fraction == 0.0
        a_fd, B_fd = _fd_principal_part("icidr", phi, L)
        assert spatial.lambda_max(a_fd, B_fd, n).max() < 0
        xi = 1e4
        for m in n[::60]:
            ev = np.linalg.eigvals(spatial.symbol_matrix(a_fd, B_fd, phi, xi, m))
            assert ev.real.max() / xi**2 < 1e-6 * np.abs(B_fd).max()


def test_mui_ill_posed_fraction_at_steady_shear():
    """mu(I) at steady shear: a proper part of the sphere is ill-posed; the Fibonacci fraction equals a Monte-Carlo
    fraction over uniform random directions with the finite-difference Gamma; the worst direction is the principal
    stretching direction (1, 0, 1)/sqrt 2 of the shear."""
    phi, L = 0.78, spatial.planar_gradient(0.0, 1 / 30, 0.0, 0.0)
    r = spatial.spatial_stability("mui", phi, L)
    assert 0.0 < r.ill_posed_fraction < 1.0 and not r.well_posed
    a_fd, B_fd = _fd_principal_part("mui", phi, L)
    n = np.random.default_rng(5).normal(size=(20000, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    lam = spatial.lambda_max(a_fd, B_fd, n)
    assert r.ill_posed_fraction == pytest.approx(np.mean(lam > 0), abs=0.015)
    assert r.max_lambda == pytest.approx(lam.max(), rel=2e-3)
    assert abs(r.worst_direction @ np.array([1, 0, 1]) / np.sqrt(2)) == pytest.approx(1.0, abs=1e-6)


def test_planar_isochoric_symbol_is_the_2d_one_plus_c_over_6():
    """Planar div-free deformation, n in the x-z plane: the 3-D Gamma is the 2-D Gamma of stability.directional
    (2-D conventions) plus c/(6 phi) n n^T, v decouples with c/(2 phi), alpha has no y component; the 4x4 symbol
    is the 3x3 2-D symbol with that shift, bordered by the v row and column."""
    rng = np.random.default_rng(2)
    th = np.deg2rad(np.arange(0.0, 180.0, 7.0))
    n2 = np.stack([np.cos(th), np.sin(th)], -1)
    n3 = np.stack([np.cos(th), 0 * th, np.sin(th)], -1)
    for name in ("mui", "icidr"):
        for _ in range(4):
            phi = float(rng.uniform(0.55, 0.8))
            ux, uz, wx = rng.normal(size=3)
            g2 = (ux, uz, wx, -ux)
            L = spatial.planar_gradient(*g2)
            a3, B3 = spatial.principal_part_at(name, phi, L)
            a2, B2 = directional.principal_part(name, phi, g2)
            G3, al3 = spatial.gamma_alpha(a3, B3, n3)
            G2, al2 = directional.gamma_alpha(a2, B2, np.rad2deg(th))
            _, c = _law(name, phi, 0.0, spatial.strain_rate_norm(L))
            xz = np.ix_(range(len(th)), [0, 2], [0, 2])
            assert np.allclose(G3[xz], G2 + c / (6 * phi) * n2[:, :, None] * n2[:, None, :], rtol=1e-10, atol=1e-12)
            assert np.allclose(G3[:, 1, 1], c / (2 * phi)) and np.allclose(G3[:, 1, [0, 2]], 0, atol=1e-12)
            assert np.allclose(al3[:, [0, 2]], al2, rtol=1e-10, atol=1e-12) and np.allclose(al3[:, 1], 0, atol=1e-12)
            A3 = spatial.symbol_matrix(a3, B3, phi, 50.0, n3[3])
            A2 = directional.symbol_matrix(a2, B2, phi, 50.0, np.rad2deg(th[3]))
            A2[1:, 1:] -= 50.0**2 * c / (6 * phi) * np.outer(n2[3], n2[3])
            assert np.allclose(A3[np.ix_([0, 1, 3], [0, 1, 3])], A2, rtol=1e-10, atol=1e-9)
            assert A3[2, 2] == pytest.approx(-50.0**2 * c / (2 * phi)) and np.allclose(A3[2, [0, 1, 3]], 0)


def test_mui_worst_rate_drops_by_one_sixth_of_M():
    """mu(I) at steady shear: the worst in-plane rate is (4 s/(phi Psi^2)) (1 - M) in 2-D and (1 - 7M/6) in 3-D."""
    phi, uz = 0.7, 0.2
    M, Psi = _M_Psi(phi)
    scale = 4 * (uz / 2) / (phi * Psi**2)
    r2 = directional.directional_stability("mui", phi, (0.0, uz, 0.0, 0.0))
    r3 = spatial.spatial_stability("mui", phi, spatial.planar_gradient(0.0, uz, 0.0, 0.0), directions=500)
    assert r2.max_lambda == pytest.approx(scale * (1 - M), rel=1e-9)
    assert r3.max_lambda == pytest.approx(scale * (1 - 7 * M / 6), rel=1e-9)


def test_exact_checks():
    """sympy: the 3-D closed form for a generic law, and the planar reduction for mu(I) and iCIDR."""
    assert {c.equation: c.status for c in spatial.checks()} == {"3-D Gamma(n)": "exact", "3-D planar": "exact"}


def test_sphere_directions_are_unit_and_balanced():
    n = spatial.sphere_directions(1000)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.abs(n.mean(axis=0)).max() < 2e-3                      # no hemisphere favoured
    assert np.allclose(n.T @ n / len(n), np.eye(3) / 3, atol=3e-3)  # isotropic second moment


@pytest.mark.parametrize("bad, word", [
    (np.zeros((3, 3)), "must not be zero"),
    ([1.0, 2.0], "9 numbers"),
    ([[1.0, np.nan, 0], [0, 0, 0], [0, 0, 0]], "9 numbers"),
])
def test_bad_gradient_is_one_clear_error(bad, word):
    with pytest.raises(ValueError, match=word):
        spatial.spatial_stability("icidr", 0.7, bad)


def test_bad_directions():
    with pytest.raises(ValueError, match="`directions` must be an integer in"):
        spatial.spatial_stability("icidr", 0.7, spatial.planar_gradient(0, 1, 0, 0), directions=3)


def test_cli_dim3_json(tmp_path, capsys):
    out = tmp_path / "s.json"
    rc = _run(["--rheology", "mui", "--phi", "0.78", "--dim", "3", "--velocity-gradient", "0", str(1 / 30), "0", "0",
               "--directions", "800", "--json", str(out)])
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["dim"] == 3 and data["sampling"]["directions"] == 800 and 0 < data["ill_posed_fraction"] < 1
    assert data["max_lambda"] > 0 and np.linalg.norm(data["worst_direction"]) == pytest.approx(1.0)
    assert data["velocity_gradient"]["u_z"] == pytest.approx(1 / 30) and len(data["velocity_gradient"]) == 9
    assert "ill_posed_fraction" in capsys.readouterr().out
    png = tmp_path / "sphere.png"
    assert _run(["--rheology", "mui", "--phi", "0.78", "--dim", "3", "--uz", str(1 / 30), "--wz", "0",
                 "--directions", "200", "--plot", str(png)]) == 0
    assert png.stat().st_size > 10000
    rc = _run(["--rheology", "icidr", "--phi", "0.7", "--dim", "3", "--velocity-gradient",
               *"0.1 0.2 0.3 -0.1 0.05 0 0.3 0 -0.2".split(), "--json", str(out)])
    assert rc == 0 and json.loads(out.read_text())["ill_posed_fraction"] == 0.0


@pytest.mark.parametrize("argv, word", [
    (["--dim", "3", "--velocity-gradient", "1", "2", "3"], "9 numbers"),
    (["--dim", "3", "--uz", "1", "--wz", "0", "--angles", "0:180:1"], "--angles"),
    (["--uz", "1", "--wz", "0", "--directions", "100"], "--directions"),
    (["--dim", "3", "--uz", "1", "--wz", "0", "--directions", "2"], "--directions"),
])
def test_cli_dim3_bad_input_exit_2(argv, word, capsys):
    assert _run(["--rheology", "icidr", "--phi", "0.7", *argv]) == 2
    err = capsys.readouterr().err
    assert word in err and err.count("\n") == 1 and "Traceback" not in err


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


@pytest.mark.parametrize("name", ["mui", "icidr"])
def test_workbench_closed_form_is_the_derived_gamma(name):
    """The workbench's 3-D Gamma (generated invariant kernels through the closed form) equals the Gamma derived by
    sympy from the 3-D stress, at rotated states of every deviator shape with vorticity."""
    from icidr_pde.rheology import INVARIANTS, get_rheology

    r = get_rheology(name)
    k = r.kernels(INVARIANTS)
    rng = np.random.default_rng(4)
    n = spatial.sphere_directions(50)
    for lode in np.deg2rad([0.0, 20.0, 30.0, 60.0]):
        phi, s, div = float(rng.uniform(0.55, 0.8)), float(rng.uniform(0.05, 2)), float(rng.uniform(-1, 1))
        Q = _rotation(rng)
        S = Q @ spatial.deviator_of_shape(s, lode) @ Q.T
        W = rng.normal(size=(3, 3))
        L = S + div / 3 * np.eye(3) + (W - W.T) / 2
        a, B = spatial.principal_part_at(name, phi, L)
        G, _ = spatial.gamma_alpha(a, B, n)
        _, c = k.stress_numpy(phi, div, s, r.material.params)
        J = np.array(k.stress_jacobian_numpy(phi, div, s, r.material.params)).reshape(2, 3)
        Gc = spatial.invariant_gamma(*(np.atleast_1d(float(v)) for v in (c, J[0, 1], J[0, 2], J[1, 1], J[1, 2], s)),
                                     S[None], n, np.atleast_1d(phi))[0]
        assert np.allclose(Gc, G, rtol=1e-9, atol=1e-10 * np.abs(G).max())


def test_workbench_3d_verdict_icidr():
    """iCIDR well-posed at every state of the workbench's 3-D grid."""
    from icidr_pde.rheology import get_rheology
    from stability.workbench import _grid_states

    r = get_rheology("icidr")
    good = spatial.grid_symbol(r, _grid_states(r))
    assert good["well_posed"] and good["max_Lambda_plus"]["Lambda_plus"] < 0


def test_law_check_prints_three_d(capsys, tmp_path):
    """`law check mui`: the 3-D line beside the 1-D and 2-D ones; in the report mu(I) is ill-posed at every state
    of the 3-D grid, on part of the sphere only."""
    from icidr_pde.cli import main

    assert main(["law", "check", "mui", "--no-curves", "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "symbol one-d: ILL-POSED" in out and "symbol two-d: ILL-POSED" in out
    assert "symbol three-d: ILL-POSED" in out and "verdict: ILL-POSED" in out
    bad = json.loads((tmp_path / "r.json").read_text())["stability"]["three_d"]
    assert not bad["well_posed"] and bad["max_Lambda_plus"]["ill_posed_states"] == bad["states"]
    assert 0 < bad["max_Lambda_plus"]["ill_posed_fraction"] < 1


def test_numbers_quoted_in_the_docs():
    """docs/plane_waves.md's 3-D table (steady shear, u_z = 1/30) is what the code computes."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "plane_waves.md").read_text()
    num = r"([0-9.]+)"
    rows = re.findall(rf"\| {num} +\| {num} +\| {num} / {num} \({num}\) +\| \[{num}°, {num}°\] / \[{num}°, {num}°\] +\| "
                      rf"{num} +\|", text)
    assert len(rows) == 2
    for row in rows:
        phi, M, r2, r3, ratio, a2, b2, a3, b3, frac = (float(v) for v in row)
        g2 = (0.0, 1 / 30, 0.0, 0.0)
        assert _M_Psi(phi)[0] == pytest.approx(M, abs=1e-4)
        d2 = directional.directional_stability("mui", phi, g2)
        r = spatial.spatial_stability("mui", phi, spatial.planar_gradient(*g2), directions=20_000)
        assert d2.max_lambda == pytest.approx(r2, rel=2e-4) and r.max_lambda == pytest.approx(r3, rel=2e-4)
        assert r.max_lambda / d2.max_lambda == pytest.approx(ratio, abs=1e-3)
        assert np.allclose(d2.ill_posed_intervals_deg, [[a2, b2]], atol=0.006)
        a, B = spatial.principal_part_at("mui", phi, spatial.planar_gradient(*g2))
        for edge, inside in ((a3, +0.02), (b3, -0.02)):
            ends = np.deg2rad([edge - inside, edge + inside])
            lam = spatial.lambda_max(a, B, np.stack([np.cos(ends), 0 * ends, np.sin(ends)], -1))
            assert lam[0] < 0 < lam[1]
        assert r.ill_posed_fraction == pytest.approx(frac, abs=3e-4)   # the docs quote 200 000 directions
        half = np.degrees(np.arccos((np.sqrt(8 * M**2 + 9) - 3) / M)) / 2    # the docs' closed form, beta = 45 deg
        assert [45 - half, 45 + half] == pytest.approx([a3, b3], abs=0.006)


def test_newtonian_law_gives_the_navier_stokes_symbol():
    """sigma = -p0(phi) I + 2 eta S + zeta div u I in 3-D is compressible Navier-Stokes, whose momentum symbol is
    -xi^2 (eta I + (zeta + eta/3) n n^T)/(rho phi): the eta/3 is the 3-D deviator's (2-D would give 0)."""
    import sympy as sp

    from stability import plane
    from stability.symbols import phi, rho

    eta, zeta, xi = sp.symbols("eta zeta xi", positive=True)
    p0 = sp.Function("p0")
    law = plane.InvariantLaw("newtonian", lambda ph, dv, sn: (p0(ph) - zeta * dv, 2 * eta))
    n = spatial.direction()
    A = spatial.symbol(law, n, xi)
    assert A.shape == (4, 4)
    target = -xi**2 * (eta * sp.eye(3) + (zeta + eta / 3) * n * n.T) / (rho * phi)
    assert all(sp.simplify(x) == 0 for x in (A[1:, 1:] - target))
    assert all(sp.simplify(x) == 0 for x in (A[1:, 0] + sp.I * xi * sp.diff(p0(phi), phi) * n / (rho * phi)))
    assert all(sp.simplify(x) == 0 for x in (A[0, 1:] + sp.I * xi * phi * n.T))
