"""GMRES preconditioned by algebraic multigrid (jacobian 'amg', :mod:`icidr_pde.engines.linear.amg_hierarchy`).

Against independent truth: the preconditioned run integrates the same ODE as the
unpreconditioned GMRES run (solver A vs solver B: the measures agree to the integrator
tolerance, the mu(I) failure time agrees), the mass is conserved to round-off, the level
operators kept while gamma changes are the Galerkin products R (I - gamma J) P (a linear
identity), and one V-cycle is a preconditioner whose GMRES iterations grow slowly with N.
"""

import numpy as np
import pytest
from scipy import sparse
from scipy.sparse import linalg

from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
from icidr_pde.engines.linear.amg_hierarchy import AmgHierarchy, amg_preconditioner
from icidr_pde.cells import choice_asks
from icidr_pde.engines.choose import AMG_SOLVER, choose
from icidr_pde.cells.plane2d.scenes import Bump2DScene
from icidr_pde.validation import ParameterError

#: one worker under pytest-xdist: the AMG kernels (and the 2-D rates they precondition) compile once,
#: not on both workers at the same time
pytestmark = pytest.mark.xdist_group("amg")

TIMES = ["0.5", "1", "2", "5", "10"]


def _jacobian(n):
    pde = ShearCell2DPDE("icidr")
    grid = pde.make_grid((n, n), 30.0)
    state = pde.make_state(grid, *Bump2DScene().initial_condition(pde.nodes(grid)))
    return sparse.csr_matrix(pde.make_jacobian(state)(0.0, state.data.ravel())), state


def _icidr(jacobian, n, times):
    from icidr_pde import run

    return run("icidr", "bump2d", (n, n), float(times[-1]), times, method="CVODE", rtol=1e-7, atol=1e-10,
               jacobian=jacobian)


@pytest.mark.parametrize("n, times", [(16, ["0.5", "1", "2"]), pytest.param(32, TIMES, marks=pytest.mark.slow)])
def test_preconditioned_run_agrees_with_unpreconditioned_and_keeps_the_mass(n, times):
    """bump2d (16^2 to t = 2; 32^2 to t = 10 in the slow run) at rtol 1e-7: max|w| and the
    velocity norm of GMRES + AMG equal those of GMRES without a preconditioner to 1e-5 relative
    (both are rtol-accurate solutions of one ODE); mass to round-off."""
    amg, plain = _icidr("amg", n, times), _icidr("krylov", n, times)
    assert amg.settings["linear_solver"] == AMG_SOLVER and plain.settings["linear_solver"] == "GMRES"
    assert amg.reason == plain.reason == "reached t_end"
    a, b = amg.to_dict(), plain.to_dict()
    for q in ("max_w", "l2_velocity"):
        for t in times:
            assert a[q][t] == pytest.approx(b[q][t], rel=1e-5), (q, t)
    assert abs(amg.mass_drift) < 1e-12 and abs(plain.mass_drift) < 1e-12


@pytest.mark.slow
def test_mui_failure_time_does_not_depend_on_the_preconditioner():
    """mu(I) bump2d 32^2 (ill-posed: the grid-scale growth ends the run): t* of GMRES + AMG
    equals t* of GMRES without a preconditioner at the same Krylov tolerance (issue 23 item 4:
    the linear solver only changes how exactly the same Newton systems are solved)."""
    from icidr_pde import run

    def t_star(jacobian):
        r = run("mui", "bump2d", (32, 32), 10.0, ["0", "10"], series_times=[], method="CVODE", rtol=1e-7,
                atol=1e-10, jacobian=jacobian)
        assert r.blew_up
        return r.t_star

    assert t_star("amg") == pytest.approx(t_star("krylov"), rel=1e-4)


def test_kept_level_operators_are_the_galerkin_products_at_the_new_gamma():
    """R P = I on every level (tentative aggregation prolongators, orthonormal columns), so the
    operators I - gamma C_l set for a new gamma are R_l ... R_0 (I - gamma J) P_0 ... P_l."""
    J, _ = _jacobian(16)
    h = AmgHierarchy(J, 3, 0.05)
    assert len(h.sizes) >= 2
    h.at(0.2)
    Jn = J[h.order][:, h.order]
    A = sparse.identity(J.shape[0], format="csr") - 0.2 * Jn
    assert abs(h.level(0) - A).max() < 1e-12 * abs(A).max()
    for level, (P, R) in enumerate(zip(h.P, h.R)):
        assert abs(R @ P - sparse.identity(P.shape[1])).max() < 1e-12
        A = R @ A @ P
        assert abs(h.level(level + 1) - A).max() < 1e-9 * abs(A).max()


def _reference_vcycle(h, r):
    """The V-cycle of AmgHierarchy written with scipy and pyamg (an independent implementation
    of the compiled one): pyamg's block Gauss-Seidel on 3 x 3 blocks, forward before and backward
    after the coarse correction, residuals and transfers by scipy, a dense solve on the coarsest
    level."""
    from pyamg.relaxation.relaxation import block_gauss_seidel

    levels = [h.level(level).tocsr() for level in range(len(h.sizes))]

    def cycle(level, b):
        A = levels[level]
        if level == len(levels) - 1:
            return np.linalg.solve(A.toarray(), b)
        x = np.zeros_like(b)
        block_gauss_seidel(A, x, b, sweep="forward", blocksize=3)
        x += h.P[level] @ cycle(level + 1, h.R[level] @ (b - A @ x))
        block_gauss_seidel(A, x, b, sweep="backward", blocksize=3)
        return x

    return cycle(0, r[h.order])[h.position]


@pytest.mark.parametrize("n", [16, 32])
def test_compiled_vcycle_equals_the_scipy_pyamg_vcycle(n):
    """The compiled V-cycle (one call, :mod:`icidr_pde.engines.amg_kernels`) gives the V-cycle
    of scipy and pyamg to round-off, at the gamma the hierarchy was built for and after a
    change of gamma."""
    J, _ = _jacobian(n)
    h = AmgHierarchy(J, 3, 0.05)
    assert len(h.sizes) >= 3 if n == 32 else len(h.sizes) >= 2
    r = np.random.default_rng(1).standard_normal(J.shape[0])
    for gamma in (0.05, 0.3):
        h.at(gamma)
        z, expected = h.vcycle(r), _reference_vcycle(h, r)
        assert np.max(np.abs(z - expected)) < 1e-12 * np.max(np.abs(expected)), gamma


def test_vcycle_iterations_grow_slower_than_without_a_preconditioner():
    """GMRES(20) on (I - gamma J) x = b to 1e-6 from 32^2 to 64^2: one V-cycle cuts the
    iterations of the unpreconditioned solve by more than half, and they grow by less than
    1.7x per doubling of N (measured 1.45x to 256^2), where the unpreconditioned ones grow by more."""
    iterations = []
    for n in (32, 64):
        J, _ = _jacobian(n)
        M = sparse.identity(J.shape[0], format="csr") - 0.05 * J
        b = np.random.default_rng(0).standard_normal(M.shape[0])
        h = AmgHierarchy(J, 3, 0.05)
        counts = []
        for apply in (h.vcycle, lambda v: v):
            count = [0]
            _, info = linalg.gmres(M, b, M=linalg.LinearOperator(M.shape, matvec=apply), rtol=1e-6, restart=20,
                                   maxiter=100, callback=lambda _: count.__setitem__(0, count[0] + 1),
                                   callback_type="pr_norm")
            assert info == 0
            counts.append(count[0])
        assert counts[0] < counts[1] / 2, counts
        iterations.append(counts)
    (amg32, plain32), (amg64, plain64) = iterations
    assert amg64 < 1.7 * amg32 and amg64 / amg32 < plain64 / plain32, iterations


def test_preconditioner_keeps_the_mass_of_its_input():
    """With the mass weights c the preconditioned vector z has c z = c r exactly."""
    J, state = _jacobian(16)
    n = state.data[0].size
    mass = np.zeros(J.shape[0])
    mass[:n] = 1.0
    def jac(t, y):
        return J

    precond = amg_preconditioner(jac, 3, mass)
    precond.setupfn(0.0, state.data.ravel(), None, False, [0], 0.05)
    r = np.random.default_rng(2).standard_normal(J.shape[0])
    z = np.zeros_like(r)
    precond.solvefn(0.0, state.data.ravel(), None, r, z, 0.05, 1e-3, 1)
    assert abs(z[:n].sum() - r[:n].sum()) < 1e-12 * np.abs(r[:n]).sum()
    assert np.linalg.norm(z) > 0


def test_amg_needs_the_2d_cell():
    with pytest.raises(ParameterError, match="`jacobian`='amg'.*fv2d"):
        choose(method="CVODE", jacobian="amg", request="pde", **choice_asks("cheb", request="pde"))
    with pytest.raises(ParameterError, match="`jacobian` must be one of"):
        choose(method="BDF", jacobian="amg", **choice_asks("fv2d"))
    choice = choose(method="CVODE", jacobian="amg", request="pde", **choice_asks("fv2d", request="pde"))
    assert (choice.engine, choice.jacobian, choice.linear_solver) == ("sundae", "amg", AMG_SOLVER)


def x_independent_runs(jacobian: str):
    """(solver, 1-D run, 2-D run) to t = 2: x-independent data on 8 x 16 cells on CVODE with the
    2-D Jacobian mode `jacobian`, and the same data on the 1-D finite volumes (scipy BDF, analytic
    Jacobian: an independent solver)."""
    from pde.solvers import Controller

    from icidr_pde.cells.shear1d.fd import ShearCellPDE
    from icidr_pde.engines.stiff import StiffSolver

    H = 30.0
    fd = ShearCellPDE("icidr", advection="central")
    g1 = fd.make_grid(16, H)
    z = fd.nodes(g1)
    s1 = fd.make_state(g1, 0.78, z / H, 0.05 * (z - H / 2) * np.exp(-(z - H / 2) ** 2 / 9))
    pde = ShearCell2DPDE("icidr")
    s2 = pde.make_state(pde.make_grid((8, 16), H), *np.broadcast_to(s1.data[:, None, :], (3, 8, 16)).copy())
    one_d = Controller(StiffSolver(fd, method="BDF", rtol=1e-9, atol=1e-12, jacobian="analytic"),
                       t_range=(0.0, 2.0), tracker=None).run(s1).data
    solver = StiffSolver(pde, method="CVODE", rtol=1e-9, atol=1e-12, jacobian=jacobian)
    two_d = Controller(solver, t_range=(0.0, 2.0), tracker=None).run(s2).data
    return solver, one_d, two_d


def test_x_independent_run_reproduces_the_1d_run():
    """x-independent data on 8 x 16 cells, CVODE + GMRES + AMG, equal the 1-D finite-volume run
    (scipy BDF, analytic Jacobian: an independent solver) to the integrators' tolerance."""
    solver, one_d, two_d = x_independent_runs("amg")
    assert solver.info["linear_solver"] == AMG_SOLVER
    assert np.max(np.abs(two_d - one_d[:, None, :])) < 1e-7
    assert np.max(np.abs(one_d[2])) > 1e-4


def test_amg_path_memory_is_checked_before_the_run(monkeypatch):
    """The hierarchy's ~7 kB a cell (measured at 256^2) is part of the memory check: at 256^2
    with 1 GB available (a run may take half) GMRES alone fits (2.5 kB a cell: 0.16 GB),
    GMRES + AMG (9.7 kB a cell: 0.64 GB) does not."""
    from icidr_pde.case import build_case
    from icidr_pde.engines.stiff import StiffSolver

    monkeypatch.setenv("ICIDR_PDE_MEMORY", "1e9")
    case = build_case("icidr", "bump2d", "fv2d", (256, 256))
    with pytest.raises(ParameterError, match="`Nx` x `Nz` = 256 x 256 .*'amg'.*multigrid"):
        StiffSolver(case.pde, method="CVODE", jacobian="amg").check_memory(case.state)
    StiffSolver(case.pde, method="CVODE", jacobian="krylov").check_memory(case.state)
