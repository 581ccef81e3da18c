"""The persistent stiff solver: py-pde integration, interrupts, failure reporting."""

import numpy as np
import pytest
from pde.solvers import Controller

from icidr_pde import ShearCellPDE, StiffSolver, run
from icidr_pde.scenes import get_scene

H = 30.0


def shear_state(eq, N=47):
    g = eq.make_grid(N, H)
    return eq.make_state(g, *get_scene("shear").initial_condition(eq.nodes(g)))


def test_registered_with_py_pde_solve():
    eq = ShearCellPDE("icidr")
    state = shear_state(eq)
    final = eq.solve(state, t_range=1.0, solver="stiff", tracker=None, rtol=1e-6, atol=1e-9)
    assert np.isfinite(final.data).all()
    assert np.max(np.abs(final.data[2])) < np.max(np.abs(state.data[2]))  # w decays


def test_interrupts_do_not_change_the_integration():
    """The integrator keeps order, step size and Jacobian across interrupts, so the
    accepted steps and the result are the same with 3 or 300 tracker interrupts."""
    eq = ShearCellPDE("icidr")
    outcomes = []
    for n_interrupts in (3, 300):
        state = shear_state(eq)
        solver = StiffSolver(eq, rtol=1e-6, atol=1e-9)
        interrupts = list(np.linspace(0, 2.0, n_interrupts))
        final = Controller(solver, t_range=2.0, tracker=[_Null(interrupts)]).run(state)
        outcomes.append((solver.stats.n_steps, final.data.copy()))
    assert outcomes[0][0] == outcomes[1][0]
    np.testing.assert_allclose(outcomes[0][1], outcomes[1][1], rtol=0, atol=1e-13)


def test_cvode_reports_its_steps_and_factorizations():
    res = run("icidr", "shear", 47, 1.0, [1.0], method="CVODE", rtol=1e-6, atol=1e-9)
    assert res.n_steps > 0 and 0 < res.n_jac <= res.n_lu <= res.n_steps + 1


class _Null:
    def __new__(cls, interrupts):
        from pde.trackers.trackers import CallbackTracker

        return CallbackTracker(lambda state, t: None, interrupts=interrupts)


@pytest.mark.parametrize("method, jacobian", [
    ("BDF", "analytic"), ("BDF", "sparse-fd"), ("Radau", "analytic"), ("Radau", "sparse-fd"),
    ("LSODA", "banded-fd"), ("LSODA", "analytic"), ("CVODE", "banded-fd"), ("CVODE", "none"),
])
def test_methods_and_jacobians_agree(method, jacobian, reference_shear_47):
    """Every integrator and Jacobian mode converges to the same solution."""
    res = run("icidr", "shear", 47, 1.0, [1.0], method=method, jacobian=jacobian, rtol=1e-8, atol=1e-11)
    assert not res.blew_up and res.jacobian == jacobian
    np.testing.assert_allclose(res.w[-1], reference_shear_47.w[-1], atol=1e-6 * 0.02)


@pytest.fixture(scope="module")
def reference_shear_47():
    return run("icidr", "shear", 47, 1.0, [1.0], rtol=1e-11, atol=1e-13)


@pytest.mark.parametrize("method, jacobian", [("LSODA", "sparse-fd"), ("BDF", "banded-fd"), ("CVODE", "sparse-fd")])
def test_unsupported_jacobian_mode_is_named(method, jacobian):
    with pytest.raises(ValueError, match="jacobian"):
        run("icidr", "shear", 21, 1.0, [1.0], method=method, jacobian=jacobian)


@pytest.mark.parametrize("method", ["BDF", "LSODA", "CVODE"])
def test_every_method_detects_the_mui_failure(method):
    """mu(I) at N = 201 fails near t = 0.015 whatever the integrator (t* is a property
    of the discrete system; different methods stop within a few percent of each other)."""
    res = run("mui", "shear", 201, 1.0, [0], method=method)
    assert res.blew_up and 0.01 < res.t_star < 0.02


def test_failed_run_keeps_what_it_computed():
    """mu(I) on a fine grid fails; the result still has t*, the reason, the snapshots
    before t*, the state at t* and the max|w| series up to t*."""
    res = run("mui", "shear", 201, 1.0, ["0", "0.005", "0.5"])
    assert res.blew_up and 0 < res.t_star < 0.1
    assert "integrator failed" in res.reason or "phi" in res.reason or "finite" in res.reason
    assert res.time_labels == ["0", "0.005"]  # 0.5 was never reached
    assert res.max_w_t[-1] == res.t_star and np.all(np.diff(res.max_w_t) >= 0)
    assert np.isfinite(np.array(res.final)).all()
    assert res.t_final == res.t_star
    assert "0.5" not in res.to_dict()["max_w"]


@pytest.mark.parametrize("kwargs, name", [
    ({"rtol": -1.0}, "rtol"), ({"atol": 0.0}, "atol"), ({"method": "RK45"}, "method"),
    ({"jacobian": "dense"}, "jacobian"), ({"t_end": -1.0}, "t_end"), ({"phi0": 0.9}, "phi0"),
    ({"times": [0.0, 5.0]}, "times"), ({"discretization": "fem"}, "discretization"),
    ({"scene": "couette"}, "scene"), ({"eps_typo": 1.0}, "eps_typo"), ({"H": 0.0}, "`H`"),
])
def test_bad_input_is_named(kwargs, name):
    args = dict(rheology="icidr", scene="shear", N=21, t_end=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        run(**args)


def test_snapshots_saved_to_hdf5(tmp_path):
    """--save writes py-pde FileStorage: the snapshots equal the in-memory ones."""
    import h5py

    path = tmp_path / "snap.h5"
    res = run("icidr", "shear", 47, 1.0, [0, 0.5, 1], save=str(path))
    with h5py.File(path) as fh:
        np.testing.assert_allclose(fh["times"][:], [0, 0.5, 1])
        np.testing.assert_allclose(fh["data"][:, 2], res.w)
