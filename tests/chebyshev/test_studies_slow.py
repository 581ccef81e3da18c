"""Long studies (pytest -m slow): the fig 4(b) sweep, grid convergence of iCIDR
(figs 6, 7) across discretizations, spectral accuracy, and run() at N = 201."""

import numpy as np
import pytest

from icidr_pde.tstar import compare_discretizations, spectral_convergence, sweep, tstar_mapping, threshold

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("discretization", ["cheb", "fd"])
def test_fig4b_sweep_has_a_threshold_and_tstar_falls(discretization):
    # section 3.2: above a threshold N every run fails, and earlier for larger N; below
    # it the numerical diffusion of the coarse grid hides the ill-posedness
    Ns = list(range(21, 202, 4))
    res = sweep(Ns, (discretization,), jobs=2, progress=False, rheology="mui",
                scene="shear", t_end=20.0)[discretization]
    mapping = tstar_mapping(res)
    thr = threshold(mapping)
    assert thr is not None and 21 < thr < 201
    assert mapping["21"] is None and mapping["47"] is None
    failing = [(int(n), t) for n, t in mapping.items() if int(n) >= thr]
    t = np.array([x for _, x in failing])
    assert np.all(np.diff(t) < 0)  # step 4 in N: decreasing for both discretizations


@pytest.mark.parametrize("scene", ["shear", "sine"])
def test_icidr_discretizations_agree(scene):
    # figs 6, 7: iCIDR is grid converged; Chebyshev 47 and 201 and finite differences 201
    # give the same w(z, t) ('lie directly on top of one another')
    out = compare_discretizations(scene, rheology="icidr", jobs=2, progress=False)
    assert not out["failed"]
    w_scale = out["max_w"][0]
    assert out["max_w"][-1] < 0.05 * w_scale  # decays towards (3.10)
    for label, diffs in out["diff"].items():
        assert max(diffs) < 0.02 * w_scale, (label, diffs)


def test_spectral_accuracy_of_icidr():
    # smooth well-posed solution: the error falls exponentially with N down to the
    # time-integration floor
    out = spectral_convergence(Ns=range(9, 50, 4), N_ref=121, jobs=2, progress=False)
    err = np.array(out["error"])
    assert np.isfinite(out["rate"]) and out["rate"] > 0.2  # > a factor 10 per 12 points
    assert err[0] / np.min(err) > 1e4
    assert len(out["fit_N"]) >= 4


def test_run_api_chebyshev_N201_paper_tstar():
    # the same headline number through run() (numba right-hand side, trackers)
    from icidr_pde import run

    res = run("mui", "shear", 201, 0.1, discretization="cheb")
    assert res.blew_up and abs(res.t_star - 0.01052) / 0.01052 < 0.05
    assert abs(res.mass_drift) < 1e-12
