"""The native engine's Chebyshev collocation (icidr_pde.cells.shear1d.native_cheb).

Against independent truth: a fourth-order difference of the native right-hand side for
its Jacobian (the C is printed from the numba template, tests/test_translate.py, whose
kernels tests/chebyshev checks against exact solutions and symbolic identities); the converged references of data/reference (t*: BDF rtol 1e-10; max|w|:
finite volumes N = 3201) to the accuracy the README states for CVODE at N = 201; mass
conservation (Clenshaw-Curtis exactness); the py-pde path's CVODE on the same equations; the
imports of a warm run in a fresh process. No timings.
"""

import json
import os

import numpy as np
import pytest

from icidr_pde.native import NativeUnavailable
from icidr_pde.cells.shear1d.native_cheb import DENSE_LU_DELTA_GAMMA, ChebProblem
from icidr_pde.native_case import ChebCase

try:
    ChebCase("icidr", "shear", 9).problem()
except NativeUnavailable as err:  # no gcc or no SUNDIALS libraries: the py-pde path is tested elsewhere
    pytest.skip(f"native engine unavailable: {err}", allow_module_level=True)

HEAVY = ("pde", "numba", "scipy", "sympy", "sksundae", "matplotlib")


def run_native(*args, **kwargs):
    """A run that must take the native engine (api.run with engine 'native')."""
    from icidr_pde.api import run

    result = run(*args, engine="native", **kwargs)
    assert result.settings["engine"] == "native"
    return result


def perturbed(case, seed, amplitude=0.05):
    """A valid state near the initial one: phi in its range, walls as (3.9)."""
    rng = np.random.default_rng(seed)
    data = case.fields(case.y0).copy()
    data[0] += 0.005 * rng.standard_normal(case.N)
    data[1:, 1:-1] += amplitude * rng.standard_normal((2, case.N - 2))
    return data.ravel()


def test_settings_are_the_py_pde_paths():
    from icidr_pde.cells.shear1d.cheb import ChebyshevShearCellPDE
    from icidr_pde.cells import choice_asks
    from icidr_pde.engines.choose import choose
    from icidr_pde.engines.sundae import DENSE_LU_DELTA_GAMMA as pde_delta_gamma
    from icidr_pde.cells.shear1d import native_cheb as cheb

    assert DENSE_LU_DELTA_GAMMA == pde_delta_gamma
    assert cheb.MAX_N == ChebyshevShearCellPDE.max_N
    assert cheb.memory_estimate(201) == ChebyshevShearCellPDE.memory_estimate(201)
    choice = choose(method="CVODE", **choice_asks("cheb"))
    assert (choice.engine, choice.linear_solver) == ("native", f"GMRES + {cheb.KRYLOV['preconditioner']} preconditioner")
    assert cheb.LINEAR_SOLVER == "krylov"
    pde_choice = choose(method="CVODE", request="pde", **choice_asks("cheb", request="pde"))
    assert (pde_choice.jacobian, pde_choice.linear_solver) == ("analytic", "dense LU (LAPACK)")


def test_native_jacobian_is_the_derivative_of_the_native_rates():
    """Fourth-order central differences of the C right-hand side, column by column."""
    for rheology in ("icidr", "mui"):
        case = ChebCase(rheology, "sine", 13)
        problem = case.problem()
        y = perturbed(case, 7, amplitude=0.02)
        J = problem.jacobian_dense(y)
        e = 1e-5
        for j in range(y.size):
            d = np.zeros(y.size)
            d[j] = e * max(1.0, abs(y[j]))
            column = (8 * (problem.rates(y + d) - problem.rates(y - d))
                      - (problem.rates(y + 2 * d) - problem.rates(y - 2 * d))) / (12 * d[j])
            assert np.allclose(J[:, j], column, rtol=1e-6, atol=1e-7 * np.max(np.abs(J))), (rheology, j)


def test_tstar_is_the_converged_one_and_the_py_pde_paths(monkeypatch):
    """README (t*): CVODE rtol 1e-7 at N = 201 with the dense LU gives t* within 1e-5 of the
    converged t* (0.0105856, BDF rtol 1e-10; the py-pde path's error is 9.9e-6); the py-pde path's
    CVODE on the same equations and the same linear solver (an ulp apart in BLAS, so not the same
    steps) agrees to the tolerance; the run fails in CVODE's error test at h_min, not at phi's
    range. (The default Krylov path: tests/test_native_cheb_krylov.py.)"""
    from icidr_pde.api import run
    from icidr_pde.cells.shear1d import native_cheb as cheb
    from icidr_pde.studies.references import reference_tstar

    monkeypatch.setattr(cheb, "LINEAR_SOLVER", "dense")

    converged = reference_tstar("cheb")["t_star"]
    result = run_native("mui", "shear", 201, 1.0, ["0", "0.01", "0.5"], discretization="cheb", method="CVODE",
                        rtol=1e-7, atol=1e-10)
    assert result.blew_up and result.discretization == "cheb" and result.settings["engine"] == "native"
    assert abs(result.t_star - converged) / converged < 2e-5
    assert "integrator failed" in result.reason and "error test failed" in result.reason
    pde_path = run("mui", "shear", 201, 1.0, ["0", "0.01", "0.5"], discretization="cheb", method="CVODE",
                   rtol=1e-7, atol=1e-10)
    assert result.t_star == pytest.approx(pde_path.t_star, rel=1e-5)
    assert result.t_final == result.t_star and result.max_w_t[-1] == result.t_star
    assert result.time_labels == ["0", "0.01"] and result.requested_times == pde_path.requested_times
    assert np.allclose(result.phi, pde_path.phi, rtol=0, atol=1e-6)
    assert result.max_w_series[-1] == pytest.approx(np.max(np.abs(result.final[2])))
    assert np.all(np.diff(result.max_w_t) > 0)
    assert abs(result.mass_drift) < 1e-13
    assert np.array_equal(result.chi_t, pde_path.chi_t[:result.chi_t.size])
    assert set(result.to_dict()) == set(pde_path.to_dict())


@pytest.mark.parametrize("linear_solver", ["dense", "krylov"])
def test_sine_reaches_the_reference(linear_solver, monkeypatch):
    """README (end to end): iCIDR sine, Chebyshev N = 201, CVODE rtol 1e-6, t = 15: max|w| at
    t = 3, 5, 10, 15 within 1e-4 of the converged reference taken at the run's points
    (measured 2.0e-5 with one BLAS thread, 6.8e-5 with two: at rtol 1e-5 the t = 15 error,
    6e-5 to 4.4e-4, depends on the rounding of the LU through CVODE's step choices), with the
    dense LU and the Krylov path alike; mass conserved to round-off (Clenshaw-Curtis is exact
    for D(phi w), so the discrete mass cannot change but by rounding; the Krylov path's GMRES
    residual would carry mass into every Newton update (3.5e-13 here, 3.4e-10 at N = 17) but
    for the projection of each step onto the initial mass)."""
    from icidr_pde.cells.shear1d import native_cheb as cheb
    from icidr_pde.studies.references import reference

    monkeypatch.setattr(cheb, "LINEAR_SOLVER", linear_solver)

    ref = reference("icidr-sine")
    result = run_native("icidr", "sine", 201, 15.0, ["0", "3", "5", "10", "15"], discretization="cheb",
                        method="CVODE", rtol=1e-6, atol=1e-9)
    assert not result.blew_up and result.t_final == 15.0
    for t, w in zip(result.times[1:], result.w[1:]):
        k = int(np.argmin(np.abs(ref["series_t"] - t)))
        ref_max = np.abs(np.interp(result.z, ref["z_series"], ref["w_series"][k])).max()
        assert abs(np.abs(w).max() - ref_max) / ref_max < 1e-4, t
    assert abs(result.mass_drift) < 1e-13
    assert result.n_steps > 0 and 0 < result.n_jac <= result.n_lu


def test_sundials_own_dense_lu_integrates_the_same_problem(monkeypatch):
    from icidr_pde.cells.shear1d import native_cheb as cheb

    monkeypatch.setattr(cheb, "LINEAR_SOLVER", "dense")
    a = run_native("mui", "shear", 65, 1.0, discretization="cheb", method="CVODE", rtol=1e-7, atol=1e-10)
    from icidr_pde.cells.shear1d import native_cheb as cheb

    saved, cheb.DENSE_SOLVER = cheb.DENSE_SOLVER, "sundials"
    try:
        b = run_native("mui", "shear", 65, 1.0, discretization="cheb", method="CVODE", rtol=1e-7, atol=1e-10)
    finally:
        cheb.DENSE_SOLVER = saved
    assert a.blew_up and b.blew_up
    assert b.t_star == pytest.approx(a.t_star, rel=1e-5)
    assert "OPENBLAS_NUM_THREADS" in os.environ or cheb.BLAS_THREADS == 1
    with pytest.raises(ValueError, match="`solver`"):
        ChebProblem(ChebCase("mui", "shear", 9).rheology, np.eye(9), solver="qr")


def test_bad_input_is_named_before_any_work():
    from icidr_pde.validation import ParameterError

    with pytest.raises(ParameterError, match="`N`"):
        run_native("icidr", "shear", 2, 1.0, discretization="cheb")
    with pytest.raises(ParameterError, match="`N` = 5000 is too large for discretization 'cheb'"):
        run_native("icidr", "shear", 5000, 1.0, discretization="cheb")
    with pytest.raises(ValueError, match=r"unknown option\(s\) \['advection'\] for discretization 'cheb'"):
        run_native("icidr", "shear", 11, 1.0, discretization="cheb", advection="upwind")


def test_cli_auto_runs_cheb_natively_and_a_failed_run_exits_3(tmp_path):
    """The default engine takes cheb + CVODE; a warm process imports no heavy library; a blow-up
    exits 3 with its JSON; --engine pde keeps the py-pde path."""
    from icidr_pde import cli

    from .test_native import cli_in_fresh_process

    argv = ["run", "--rheology", "mui", "--discretization", "cheb", "--N", "101", "--t-end", "1",
            "--no-progress"]
    assert cli.main(argv + ["--json", str(tmp_path / "warm.json")]) == 3  # builds the library if missing
    target = tmp_path / "t.json"
    proc, status, modules = cli_in_fresh_process(argv + ["--json", str(target)])
    assert status == 3, proc.stderr
    assert "compiling" not in proc.stderr
    assert not set(HEAVY) & set(modules), set(HEAVY) & set(modules)
    data = json.loads(target.read_text())
    assert data["blew_up"] and data["settings"]["engine"] == "native" and data["discretization"] == "cheb"
    assert 0 < data["t_star"] < 0.05 and "integrator failed" in data["reason"]
    pde_path = tmp_path / "p.json"
    assert cli.main(argv + ["--json", str(pde_path), "--engine", "pde"]) == 3
    pde_data = json.loads(pde_path.read_text())
    assert pde_data["settings"]["engine"] == "sundae" and set(pde_data) == set(data)
    # the default Krylov path against the py-pde path's dense LU: to the t* spread of the standard
    # tolerance, rtol 1e-5 (6e-4 measured; the dense LUs of the two paths agree to 1e-4)
    assert data["t_star"] == pytest.approx(pde_data["t_star"], rel=2e-3)


def test_without_lapack_the_plain_loops_compute_the_same(monkeypatch):
    """Where scikit-sundae ships no LAPACK solver (and so no OpenBLAS) the library is built with
    SUNDIALS' own dense LU and plain C loops for the products with D: the same rates and
    Jacobian as the numba/numpy kernels, the same t* as the LAPACK build to the tolerance."""
    from icidr_pde.case import build_case
    from icidr_pde.native import build
    from icidr_pde.cells.shear1d import native_cheb as cheb

    monkeypatch.setattr(cheb, "LINEAR_SOLVER", "dense")
    lapack_run = run_native("mui", "shear", 101, 1.0, discretization="cheb", method="CVODE", rtol=1e-7, atol=1e-10)
    monkeypatch.setattr(build, "_lapack_dense", lambda libs: [])
    N = 29
    c = build_case("icidr", "sine", "cheb", N)
    case = ChebCase("icidr", "sine", N)
    monkeypatch.setattr(cheb, "LINEAR_SOLVER", "krylov")
    problem = case.problem()
    assert "lapackdense" not in " ".join(str(p) for p in build.sundials()[1])
    assert problem.linear_solver == "dense"  # the default Krylov path needs LAPACK: the dense LU is taken
    y = perturbed(case, 3)
    theirs, mine = c.pde.make_rates(c.state)(y.reshape(3, N)), problem.rates(y).reshape(3, N)
    for k in range(3):
        assert np.max(np.abs(mine[k] - theirs[k])) <= 1e-13 * np.max(np.abs(theirs[k])), k
    J_ref = c.pde.make_jacobian(c.state)(0.0, y)
    assert np.max(np.abs(problem.jacobian_dense(y) - J_ref)) <= 1e-13 * np.max(np.abs(J_ref))
    plain = run_native("mui", "shear", 101, 1.0, discretization="cheb", method="CVODE", rtol=1e-7, atol=1e-10)
    assert plain.blew_up and plain.t_star == pytest.approx(lapack_run.t_star, rel=1e-5)
    assert cheb.DENSE_SOLVER == "lapack"  # asked for, and SUNDIALS' own taken: the build has no other
