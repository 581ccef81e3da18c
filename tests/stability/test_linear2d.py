"""stability.linear2d: the linearized 2-D continuum problem against independent truths.

* about uniform simple shear the rates converge spectrally in the Chebyshev points, iCIDR's are
  negative and tend to the bounded third root of the plane-wave symbol at n = e_z (the 2-D form of
  -C/B, :func:`stability.directional.third_root_limit`, compiled from :mod:`stability.plane`'s
  sympy stress tensor, not from the cell's kernels);
* mu(I)'s rate grows like kappa^2 and approaches the plane-wave symbol's sup over the wave vectors
  (kappa, m) of the same x-wave number (ill-posed: unbounded in k);
* the collocated operator applied to a perturbation equals the 2-D cell's own Jacobian (fv2d)
  applied to the same perturbation, to the cell's second order, about a z-varying base with w0 != 0;
* the derivatives taken from the cell's plane-flow kernels equal those of stability.plane's sympy tensor.
"""

import numpy as np
import pytest

from stability import directional, linear2d

PHI0, H, L = 0.78, 30.0, 30.0


def test_reduced_and_generalized_agree():
    op = linear2d.Linear2D("icidr", linear2d.simple_shear(PHI0, H), L, 24)
    for k in (1, 5):
        red = op.eigenvalues(k, "reduced")
        gen = op.eigenvalues(k, "generalized")
        assert red.size == gen.size == 3 * 24 - 4
        gap = np.abs(red[:, None] - gen[None, :]).min(axis=1)
        assert np.all(gap < 1e-7 * np.maximum(np.abs(red), 1.0))
        assert red[0].real == pytest.approx(gen[0].real, rel=1e-8)


def test_icidr_simple_shear_converges_and_decays():
    """The top of iCIDR's spectrum is the edge of a continuous one (phi advected by u0(z), the bounded
    third root at large z-wave numbers), so the Chebyshev rate settles only to ~1e-5 (not spectrally):
    to the third root's limit at n = e_z within 2e-3, from a clearly worse 24-point value."""
    base = linear2d.simple_shear(PHI0, H)
    ops = {n: linear2d.Linear2D("icidr", base, L, n) for n in (24, 64)}
    a, B = directional.principal_part("icidr", PHI0, (0.0, 1.0 / H, 0.0, 0.0))
    G, al = directional.gamma_alpha(a, B, [90.0])
    limit = float(directional.third_root_limit(G, al, directional.directions([90.0]), PHI0)[0])
    assert -0.03 < limit < -0.025
    for k in (1, 4):
        r = {n: op.rate(k) for n, op in ops.items()}
        assert max(r.values()) < 0
        assert abs(r[64] / limit - 1) < 2e-3
    assert abs(ops[24].rate(4) / limit - 1) > 0.1                   # 24 points do not resolve k = 4 yet


def _symbol_sup(kappa, a, B, phi0):
    """sup over directions of max Re eig A(xi, n) with the x-component xi cos(theta) = kappa."""
    theta = np.linspace(0.5, 89.5, 359)
    best = -np.inf
    for t in theta:
        xi = kappa / np.cos(np.radians(t))
        best = max(best, np.linalg.eigvals(directional.symbol_matrix(a, B, phi0, xi, t)).real.max())
    return best


def test_mui_grows_like_its_symbol():
    base = linear2d.simple_shear(PHI0, H)
    op = linear2d.Linear2D("mui", base, L, 64)
    a, B = directional.principal_part("mui", PHI0, (0.0, 1.0 / H, 0.0, 0.0))
    ks = (2, 4, 8)
    rates = np.array([op.rate(k) for k in ks])
    ratios = np.array([r / _symbol_sup(op.wavenumber(k), a, B, PHI0) for k, r in zip(ks, rates)])
    assert np.all(np.diff(rates) > 0) and rates[0] > 0
    assert 4 < rates[2] / rates[1] < 5 and rates[2] / rates[1] < rates[1] / rates[0]   # -> 4: kappa^2
    assert np.all(np.diff(np.abs(1 - ratios)) < 0)                  # the ratio tends to 1 ...
    assert abs(1 - ratios[-1]) < 0.02                               # ... and is close at k = 8
    # the top eigenvalue is discrete: spectral convergence (48 points: 10 digits; 32 points: 3)
    assert abs(linear2d.Linear2D("mui", base, L, 48).rate(4) / rates[1] - 1) < 1e-8


def _trig_base():
    """phi0 = 0.78 + 0.01 cos(pi z/H), u0 = z/H + 0.05 sin(pi z/H), w0 = 0.05 sin(2 pi z/H): walls as the cell's."""
    q = np.pi / H

    def phi(z, nu=0):
        return (0.78 if nu == 0 else 0.0) + 0.01 * q**nu * np.cos(q * z + nu * np.pi / 2)

    def u(z, nu=0):
        lin = z / H if nu == 0 else (1 / H if nu == 1 else 0.0 * z)
        return lin + 0.05 * q**nu * np.sin(q * z + nu * np.pi / 2)

    def w(z, nu=0):
        return 0.05 * (2 * q)**nu * np.sin(2 * q * z + nu * np.pi / 2)

    return linear2d.BaseState(H, 1.0, phi, u, w, "trigonometric")


def _perturbation(z, field):
    """A perturbation of one field (phi^ of zero gradient, u^ and w^ zero at the walls, as the cell's)."""
    q = np.pi / H
    out = np.zeros((3, z.size), complex)
    out[field] = [(1 + 0.5j) * np.cos(q * z) + 0.3 * np.cos(2 * q * z),
                  np.sin(q * z) * (1 + 0.5j * z / H),
                  (1 - 0.5j) * np.sin(2 * q * z)][field]
    return out


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_operator_is_the_cells_linearization(rheology):
    """Each block (row field, perturbed field) of the operator against the 2-D cell's Jacobian, relative to the
    block's own size, away from the walls (the cell's wall rows are first order there)."""
    from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
    from icidr_pde.cells.shear1d.cheb_core import interpolate

    base, k = _trig_base(), 2
    op = linear2d.Linear2D(rheology, base, L, 40)
    errors = []
    for nx, nz in ((32, 24), (64, 48)):
        pde = ShearCell2DPDE(rheology)
        grid = pde.make_grid((nx, nz), H, L=L)
        xz = pde.nodes(grid)
        x, z = xz[:, 0, 0], xz[0, :, 1]
        state = pde.make_state(grid, *(np.broadcast_to(f, (nx, nz)) for f in base.fields(z)))
        J = pde.make_jacobian(state)(0.0, state.data.ravel())
        wave = np.exp(1j * op.wavenumber(k) * x)
        inner = (z > H / 8) & (z < 7 * H / 8)
        err = np.zeros((3, 3))
        for field in range(3):
            v = np.real(_perturbation(z, field)[:, None, :] * wave[None, :, None])     # (3, nx, nz)
            Jv = (J @ v.ravel()).reshape(3, nx, nz)
            disc = 2 / nx * np.einsum("fxz,x->fz", Jv, np.conj(wave))                 # the k-th x-coefficient
            cont_nodes = op.apply(k, _perturbation(op.z, field))
            cont = interpolate(cont_nodes.real, z, H) + 1j * interpolate(cont_nodes.imag, z, H)
            for row in range(3):
                err[row, field] = np.abs(disc[row, inner] - cont[row, inner]).max() / np.abs(cont[row]).max()
        errors.append(err)
    assert errors[1].max() < 0.015
    assert np.all(errors[1] < 0.3 * errors[0])                           # second order, block by block


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_cell_kernels_are_the_plane_stress_tensor(rheology):
    """The derivatives linear2d takes from the cell's plane-flow kernels equal rho phi a_ij and rho phi B_ijkl of
    stability.plane's sympy stress tensor (one law, two routes), at a general velocity gradient."""
    from icidr_pde.rheology import PLANE_FLOW, get_rheology

    phi0, grad = 0.79, (0.01, 1 / H, -0.005, 0.02)               # (u_x, u_z, w_x, w_z)
    a, B = directional.principal_part(rheology, phi0, grad)
    r = get_rheology(rheology)
    jac = np.array(r.kernels(PLANE_FLOW).stress_jacobian_numpy(
        *(np.array([v]) for v in (phi0, *grad)), r.material.params), float).reshape(4, 5)
    sigma = {(0, 0): jac[1] - jac[0], (0, 1): jac[2], (1, 0): jac[2], (1, 1): jac[3] - jac[0]}
    entry = {(0, 0): 1, (0, 1): 2, (1, 0): 3, (1, 1): 4}           # L[k, l] -> kernel input
    for (i, j), d in sigma.items():
        assert d[0] == pytest.approx(phi0 * a[i, j], rel=1e-10, abs=1e-12)
        for (k, l), q in entry.items():
            assert d[q] == pytest.approx(phi0 * B[i, j, k, l], rel=1e-10, abs=1e-12)


def test_snapshot_base_of_steady_shear_is_simple_shear():
    """A snapshot of the cell's steady shear (cell centres, x-independent) gives back u = z/H, phi0, w = 0 with
    the walls' values of the cell, and the same rates as simple_shear."""
    nx, nz = 8, 16
    z = (np.arange(nz) + 0.5) * H / nz
    data = np.stack([np.full((nx, nz), PHI0), np.broadcast_to(z / H, (nx, nz)), np.zeros((nx, nz))])
    base = linear2d.from_snapshot(data, H=H)
    zz = np.linspace(0, H, 7)
    assert np.allclose(base.fields(zz), linear2d.simple_shear(PHI0, H).fields(zz), atol=1e-13)
    assert np.allclose(base.fields(zz, 1)[1], 1 / H, atol=1e-13)
    a = linear2d.Linear2D("icidr", base, L, 24).rate(3)
    assert a == pytest.approx(linear2d.Linear2D("icidr", linear2d.simple_shear(PHI0, H), L, 24).rate(3), rel=1e-9)
