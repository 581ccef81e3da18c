"""The native engine's Newton-Krylov path for Chebyshev collocation (linear_solver 'krylov').

Against independent truth: the low-order preconditioner's Jacobian converges to the spectral
one at second order on smooth data (three-point differences on the CGL points) and writes
only the band (5, 5) of the interleaved ordering; t* against the converged reference of
data/reference (BDF rtol 1e-10) and against the dense LU on the same equations at a tight
tolerance; mass conserved (Clenshaw-Curtis); iCIDR sine against its reference on either linear solver:
tests/test_native_cheb.py. No timings.
"""

import numpy as np
import pytest

from icidr_pde.native import NativeUnavailable
from icidr_pde.cells.shear1d import native_cheb as cheb
from icidr_pde.cells.shear1d.native_cheb import ChebProblem
from icidr_pde.native_case import ChebCase

from .test_native_cheb import run_native

try:
    ChebCase("mui", "shear", 9).problem(linear_solver="krylov")
except NativeUnavailable as err:  # no gcc, no SUNDIALS, or no SPGMR/LAPACK: the dense path is tested elsewhere
    pytest.skip(f"native Krylov path unavailable: {err}", allow_module_level=True)


@pytest.fixture
def krylov(request):
    """Runs in the test take the Krylov path with the preconditioner of the parameter."""
    saved, saved_settings = cheb.LINEAR_SOLVER, dict(cheb.KRYLOV)
    cheb.LINEAR_SOLVER = "krylov"
    cheb.KRYLOV["preconditioner"] = getattr(request, "param", "band")
    yield cheb.KRYLOV["preconditioner"]
    cheb.LINEAR_SOLVER = saved
    cheb.KRYLOV.clear()
    cheb.KRYLOV.update(saved_settings)


def smooth_state(case):
    """A smooth valid state and a smooth direction, both with the walls of (3.9) (u, w fixed there)."""
    z, H, N = case.z, case.H, case.N
    s = np.sin(np.pi * z / H)
    y = np.concatenate([0.78 + 0.01 * np.cos(np.pi * z / H), z / H + 0.05 * np.sin(2 * np.pi * z / H), 0.02 * s])
    v = np.concatenate([np.cos(2 * np.pi * z / H), 0.3 * s * np.cos(np.pi * z / H), s ** 2])
    return y, v


def interleaving(N):
    """index into the block ordering (phi, u, w) of each entry of the interleaved one (phi_0, u_0, w_0, ...)"""
    return np.arange(3 * N).reshape(3, N).T.ravel()


@pytest.mark.parametrize("rheology", ["mui", "icidr"])
def test_low_order_jacobian_converges_to_the_spectral_one_at_second_order(rheology):
    errors = []
    for N in (41, 81, 161):
        case = ChebCase(rheology, "shear", N)
        problem = case.problem()
        assert np.max(np.abs(problem.nodes() - case.z)) < 1e-12 * case.H
        y, v = smooth_state(case)
        perm = interleaving(N)
        J_lo = problem.jacobian_low_order(y)
        exact = problem.jacobian_dense(y) @ v
        approx = np.empty(3 * N)
        approx[perm] = J_lo @ v[perm]
        interior = np.r_[1:N - 1]  # the mass rows' walls are one-sided, first order
        rows = np.concatenate([interior, N + interior, 2 * N + interior])
        errors.append(np.max(np.abs(approx - exact)[rows]) / np.max(np.abs(exact[rows])))
        offsets = np.subtract.outer(np.arange(3 * N), np.arange(3 * N))
        assert np.all(J_lo[np.abs(offsets) > 5] == 0)
        walls = [3 * 0 + 1, 3 * 0 + 2, 3 * (N - 1) + 1, 3 * (N - 1) + 2]
        assert np.all(J_lo[walls] == 0)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.7), (errors, orders)


@pytest.mark.parametrize("krylov", ["band", "dense"], indirect=True)
def test_tstar_is_the_converged_one_and_the_dense_lus(krylov):
    """mu(I) shear, N = 201, CVODE rtol 1e-7: t* within 2e-4 of the converged t* (0.0105856,
    BDF rtol 1e-10; the dense LU's error 2e-6, the Krylov path's measured 7.5e-5 (band) and
    5.8e-5 (lagged dense): docs/chebyshev.md); the same reason of failure; mass to 1e-12 (Clenshaw-
    Curtis: round-off and the mass of GMRES's residuals, tests/test_native_cheb.py)."""
    from icidr_pde.studies.references import reference_tstar

    converged = reference_tstar("cheb")["t_star"]
    result = run_native("mui", "shear", 201, 1.0, ["0", "0.01"], discretization="cheb", method="CVODE",
                        rtol=1e-7, atol=1e-10)
    assert result.blew_up and result.settings["engine"] == "native"
    assert abs(result.t_star - converged) / converged < 2e-4
    assert "integrator failed" in result.reason and "error test failed" in result.reason
    assert abs(result.mass_drift) < 1e-12
    assert 0 < result.n_jac <= result.n_lu


@pytest.mark.parametrize("krylov", ["band"], indirect=True)
def test_tstar_does_not_move_with_the_krylov_tolerance(krylov):
    """N = 101, rtol 1e-7: GMRES tolerance factors 0.05 (CVODE's default) and 5e-4 give one t* to
    1e-5 and the dense LU's to 3e-5: the spread of t* between CVODE tolerances rtol 1e-7 and 1e-8
    (7e-6 with the dense LU, 1.7e-5 with the band preconditioner, docs/chebyshev.md)."""
    t = {}
    for eps_lin in (0.05, 5e-4):
        cheb.KRYLOV["eps_lin"] = eps_lin
        t[eps_lin] = run_native("mui", "shear", 101, 1.0, discretization="cheb", method="CVODE",
                                rtol=1e-7, atol=1e-10).t_star
    cheb.LINEAR_SOLVER = "dense"
    dense = run_native("mui", "shear", 101, 1.0, discretization="cheb", method="CVODE", rtol=1e-7, atol=1e-10).t_star
    assert abs(t[0.05] - t[5e-4]) / dense < 1e-5, t
    for value in t.values():
        assert abs(value - dense) / dense < 3e-5, (t, dense)


def test_counts_and_bad_settings():
    case = ChebCase("mui", "shear", 33)
    problem = case.problem(linear_solver="krylov", krylov={"preconditioner": "band"})
    problem.start(case.y0, rtol=1e-6, atol=1e-9)
    n = 40
    problem.advance(np.linspace(1e-4, 4e-3, n), np.full(n, -1, dtype=np.intc), np.empty(n), np.empty((1, 99)))
    counts = problem.counts()
    assert counts["krylov_iterations"] > 0 and counts["jv"] == counts["jv_rhs"] == counts["krylov_iterations"]
    assert counts["preconditioner_solves"] >= counts["newton_iterations"] > 0
    assert counts["lu"] >= counts["jac"] > 0
    rheology = case.rheology
    with pytest.raises(ValueError, match="`linear_solver`"):
        ChebProblem(rheology, case.scheme.D, linear_solver="qr")
    with pytest.raises(ValueError, match="preconditioner"):
        ChebProblem(rheology, case.scheme.D, linear_solver="krylov", krylov={"preconditioner": "ilu"})
    with pytest.raises(ValueError, match="`krylov` takes the keys"):
        ChebProblem(rheology, case.scheme.D, linear_solver="krylov", krylov={"restarts": 3})


def test_low_order_c_is_the_numba_template():
    """templates/cheb.py low_order_jacobian compiled by numba and printed as C: the same band."""
    from icidr_pde.case import build_case

    N = 33
    c = build_case("mui", "sine", "cheb", N)
    case = ChebCase("mui", "sine", N)
    y, _ = smooth_state(case)
    z, D = c.pde.operators(c.grid)[:2]
    B = np.zeros((3 * N, 3 * N))
    case.scheme.loops().low_order_jacobian(y.reshape(3, N), D, z, c.pde.material.params, B)
    mine = case.problem().jacobian_low_order(y)
    assert np.max(np.abs(mine - B)) <= 1e-13 * np.max(np.abs(B))


@pytest.mark.parametrize("accuracy, within", [("standard", 1e-3), ("publication", 1e-5)])
def test_the_presets_tstar_is_within_its_stated_accuracy(accuracy, within):
    """icidr_pde.presets: mu(I) shear, N = 201, the native default (GMRES, band preconditioner) at a
    preset's Chebyshev tolerances gives t* within 1e-3 (standard) or 1e-5 (publication) of the converged
    t* of scipy's BDF at rtol 1e-10 (data/reference; measured 7.4e-5 and 1.4e-6, load 1.9: icidr_pde.presets)."""
    from icidr_pde.studies.references import reference_tstar

    converged = reference_tstar("cheb")["t_star"]
    result = run_native("mui", "shear", 201, 0.05, discretization="cheb", accuracy=accuracy)
    assert result.blew_up and result.settings["linear_solver"].startswith("GMRES")
    assert abs(result.t_star - converged) / converged < within


def test_the_memory_check_takes_the_linear_solvers_estimate(monkeypatch):
    """icidr_pde.discretizations.grid_size.CHEB: with 1.2 GB available N = 2001 fits the Krylov path
    (D and vectors, 0.07 GB) and not the dense LU (0.93 GB), refused before anything is allocated."""
    from icidr_pde.validation import ParameterError

    monkeypatch.setenv("ICIDR_PDE_MEMORY", "1.2e9")
    case = ChebCase("mui", "shear", 2001)
    with pytest.raises(ParameterError, match=r"`N` = 2001 is too large for discretization 'cheb' with linear "
                                             r"solver 'dense'.*dense 3N x 3N"):
        case.problem(linear_solver="dense")
    with pytest.raises(ParameterError, match="linear solver 'krylov': it"):  # the lagged dense LU is dense too
        case.problem(linear_solver="krylov", krylov={"preconditioner": "dense"})
    assert case.problem(linear_solver="krylov", krylov={"preconditioner": "band"}).linear_solver == "krylov"
