"""The compiled banded Jacobian of the finite-volume scheme (CVODE's default Jacobian)."""

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde.case import build_case

from .oracles import oracle_rhs

#: one worker under pytest-xdist: the banded Jacobian kernels compile once, not on both workers at the
#: same time
pytestmark = pytest.mark.xdist_group("band_jacobian")


@pytest.mark.parametrize("rheology, scene, advection", [("icidr", "sine", "upwind"), ("mui", "shear", "upwind"),
                                                         ("icidr", "shear", "central")])
def test_band_jacobian_matches_finite_differences(rheology, scene, advection):
    case = build_case(rheology, scene, N=15, options=dict(advection=advection))
    rng = np.random.default_rng(1)
    case.state.data[...] += 1e-3 * rng.random(case.state.data.shape)
    pde, state = case.pde, case.state
    perm, lband, uband = pde.interleaving(state)
    rhs = oracle_rhs(pde, state)
    y = state.data.ravel()[perm]
    inverse = np.argsort(perm)

    def f(y):
        return rhs(y[inverse].reshape(state.data.shape), 0.0).ravel()[perm]

    J = np.full((y.size, y.size), np.nan)
    pde.make_band_jacobian(state)(y, J)
    fd = np.empty_like(J)
    for k in range(y.size):
        step = 1e-6 * max(1.0, abs(y[k]))
        e = np.zeros_like(y)
        e[k] = step
        fd[:, k] = (f(y + e) - f(y - e)) / (2 * step)
    rows, cols = np.indices(J.shape)
    in_stencil = np.abs(rows // 3 - cols // 3) <= 1
    assert np.all(np.isnan(J[~in_stencil]))  # nothing written outside the cells' blocks
    assert np.all(np.abs(fd[~in_stencil]) == 0) and np.all(np.abs(rows - cols)[in_stencil] <= max(lband, uband))
    np.testing.assert_allclose(J[in_stencil], fd[in_stencil], atol=1e-6 * np.abs(fd).max())
    # conservative phi rows: every column of d(dphi/dt)/dy sums to zero (mass flux differences)
    assert np.abs(np.nansum(np.where(in_stencil, J, 0)[0::3], axis=0)).max() <= 1e-13 * np.abs(fd).max()


@pytest.mark.parametrize("scene", ["shear", "sine"])
def test_cvode_default_conserves_mass_to_round_off(scene):
    """Issue 15 item 6 on the default path: 2.5e-11 drift with CVODE's difference quotients."""
    res = run("icidr", scene, 7, 10.0, [10.0], progress=False)
    assert res.jacobian == "analytic" and not res.blew_up
    assert abs(res.mass_drift) < 1e-14
