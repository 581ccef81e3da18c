"""ChebyshevShearCellPDE: the interface run() relies on, exact properties of the
collocation scheme (steady state, walls, mass) and the analytic Jacobian."""

import numpy as np
import pytest
from pde.pdes.base import PDEBase

from icidr_pde.case import make_pde
from icidr_pde.discretizations import DISCRETIZATIONS
from icidr_pde.cells.shear1d.cheb import ChebyshevShearCellPDE, cc_weights, cgl_nodes
from icidr_pde.rheology import MuIPhiI
from icidr_pde.scenes import get_scene

H = 30.0


def _perturbed_state(pde, N, seed=0):
    """A generic smooth state: sine scene (5.7) plus smooth phi and w perturbations."""
    grid = pde.make_grid(N, H)
    z = pde.nodes(grid)
    state = pde.make_state(grid, *get_scene("sine").initial_condition(z))
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.5, 1.5, 3)
    state.data[0] += 0.01 * np.cos(a[0] * z / 3)
    state.data[2, 1:-1] += 0.02 * np.sin(a[1] * z[1:-1] / 4) * np.sin(np.pi * z[1:-1] / H)
    state.data[1, 1:-1] += 0.03 * np.sin(3 * np.pi * z[1:-1] / H)
    return grid, state


def test_registered_and_interface():
    assert DISCRETIZATIONS["cheb"] is ChebyshevShearCellPDE
    pde = make_pde("mui", "cheb")
    assert isinstance(pde, PDEBase) and isinstance(pde.rheology, MuIPhiI)
    assert pde.material is pde.rheology.material and pde.V0 == 1.0
    grid = pde.make_grid(11, H)
    assert grid.shape == (11,) and tuple(grid.axes_bounds[0]) == (0.0, H)
    np.testing.assert_allclose(pde.nodes(grid), cgl_nodes(11, H))
    state = pde.make_state(grid, 0.78, lambda z: z / H, 0.0)
    assert pde.jacobian_sparsity(state) is None
    J = pde.make_jacobian(state)(0.0, state.data.ravel())
    assert isinstance(J, np.ndarray) and J.shape == (33, 33)
    assert pde.check_state(state.data) is None
    assert pde.interleaving(state) is None  # no banded ordering for a dense Jacobian
    np.testing.assert_allclose(pde.validity_margins(state.data), [0.78, pde.material.phi_c - 0.78])
    bad = state.data.copy()
    bad[0, 3] = 0.9
    assert "phi" in pde.check_state(bad)
    assert pde.validity_margins(bad)[1] < 0
    with pytest.raises(ValueError):
        pde.make_grid(3)
    with pytest.raises(ValueError):
        ChebyshevShearCellPDE("newtonian")


def test_make_state_sets_dirichlet_walls():
    pde = ChebyshevShearCellPDE("icidr", V0=1.0)
    grid = pde.make_grid(15, H)
    state = pde.make_state(grid, *get_scene("shear").initial_condition(pde.nodes(grid)))
    phi, u, w = state.data
    assert u[0] == 0.0 and u[-1] == 1.0 and w[0] == 0.0 and w[-1] == 0.0
    z = pde.nodes(grid)
    np.testing.assert_allclose(w[1:-1], 0.05 * (z[1:-1] - 15) * np.exp(-(z[1:-1] - 15) ** 2))
    np.testing.assert_allclose(phi, 0.78)


@pytest.mark.parametrize("rheology", ["mui", "icidr"])
def test_walls_and_mass(rheology):
    pde = ChebyshevShearCellPDE(rheology)
    grid, state = _perturbed_state(pde, 23)
    rate = pde.evolution_rate(state).data
    assert np.all(rate[1:, [0, -1]] == 0)  # Dirichlet u, w
    assert np.all(rate[0, [0, -1]] != 0)  # phi evolves at the walls
    c = cc_weights(23, H)
    # d/dt of the Clenshaw-Curtis mass: -(phi w)(H) + (phi w)(0) = 0 since w = 0 at walls
    assert abs(c @ rate[0]) < 1e-14 * np.sum(c * np.abs(rate[0])) * 23
    assert abs(pde.integral(state.data[0], grid) - c @ state.data[0]) == 0


def test_rhs_against_independent_formula():
    # d_t u = (1/phi) d_z tau_xz - w u_z with exact derivatives of polynomial fields
    pde = ChebyshevShearCellPDE("mui")
    N = 30
    grid = pde.make_grid(N, H)
    z = pde.nodes(grid)
    s = z / H
    phi = 0.78 + 0.01 * s * (1 - s)
    u = s + 0.1 * s**2 * (1 - s)
    w = 0.05 * s * (1 - s) * (s - 0.3)
    state = pde.make_state(grid, phi, u, w)
    uz = (1 + 0.1 * (2 * s - 3 * s**2)) / H
    wz = 0.05 * (-3 * s**2 + 2.6 * s - 0.3) / H
    p, txz, tzz = pde.rheology.stress(phi, uz, wz)
    # txz is not a polynomial: compare against the spectrally accurate D of a fine grid
    rate = pde.evolution_rate(state).data
    phiw_z = (0.01 * (1 - 2 * s) / H) * w + phi * wz
    np.testing.assert_allclose(rate[0], -phiw_z, atol=1e-14)
    z_f = cgl_nodes(121, H)
    from icidr_pde.cells.shear1d.cheb import diff_matrix

    def fine(f):
        sf = z_f / H
        return f(sf)

    phif = fine(lambda s: 0.78 + 0.01 * s * (1 - s))
    uzf = fine(lambda s: (1 + 0.1 * (2 * s - 3 * s**2)) / H)
    wzf = fine(lambda s: 0.05 * (-3 * s**2 + 2.6 * s - 0.3) / H)
    _, txz_f, _ = pde.rheology.stress(phif, uzf, wzf)
    dtxz_f = diff_matrix(121, H) @ txz_f
    # interpolate the fine derivative to the coarse nodes
    dtxz = np.polynomial.chebyshev.Chebyshev.fit(z_f, dtxz_f, 120, domain=[0, H])(z)
    expected = dtxz / phi - w * uz
    np.testing.assert_allclose(rate[1, 1:-1], expected[1:-1], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("rheology", ["mui", "icidr"])
def test_jacobian_dirichlet_rows_vanish(rheology):
    # u and w are fixed at the walls (3.9); the Jacobian against finite differences is in
    # tests/test_discretization_contract.py
    pde = ChebyshevShearCellPDE(rheology)
    N = 13
    grid, state = _perturbed_state(pde, N, seed=1)
    J = pde.make_jacobian(state)(0.0, state.data.ravel().copy())
    for row in (N, 2 * N - 1, 2 * N, 3 * N - 1):
        assert not np.any(J[row])


def test_strain_rates_at_collocation_points():
    pde = ChebyshevShearCellPDE("icidr")
    grid = pde.make_grid(9, H)
    state = pde.make_state(grid, 0.7, lambda z: (z / H) ** 2, lambda z: z * (H - z))
    z, phi, uz, wz = pde.strain_rates(state.data, grid)
    np.testing.assert_allclose(z, cgl_nodes(9, H))
    np.testing.assert_allclose(uz, 2 * z / H**2, atol=1e-14)
    np.testing.assert_allclose(wz, H - 2 * z, atol=1e-12)
    np.testing.assert_allclose(phi, 0.7)


def test_run_api_with_chebyshev():
    # run() end to end (numba right-hand side, recorders, Result) on the N of the test
    # above, so the compiled kernels are shared
    from icidr_pde import run

    res = run("icidr", "sine", 17, 0.5, discretization="cheb", times=[0.0, 0.5])
    assert not res.blew_up and res.discretization == "cheb" and res.N == 17
    np.testing.assert_allclose(res.z, cgl_nodes(17, H))
    assert abs(res.mass_drift) < 1e-12
    assert res.chi is not None and res.chi.shape[1] == 17
    assert res.max_w_series[-1] < res.max_w_series[0]  # iCIDR decays towards (3.10)
    # walls stay at the Dirichlet data (up to round-off of BDF's dense output)
    np.testing.assert_allclose([res.u[-1][0], res.u[-1][-1], res.w[-1][0], res.w[-1][-1]],
                               [0, 1, 0, 0], atol=1e-14)
