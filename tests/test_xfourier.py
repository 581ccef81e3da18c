"""GMRES preconditioned by the x-average of the Jacobian (jacobian 'fourier', :mod:`icidr_pde.engines.linear.xfourier_inverse`).

Against independent truth: on a state that does not depend on x the preconditioner is the exact
inverse of CVODE's Newton matrix I - gamma J (SuperLU of the sparse matrix); on any state it is
the inverse of the average of the x-shifted Jacobians (1/Nx) sum_s S^-s J S^s, built here by
permuting J, not by the FFT; it keeps the mass (a linear identity: the phi rows of J sum to zero
in every column); and the preconditioned run integrates the same ODE as the unpreconditioned one
(solver A against solver B), the mu(I) failure time included.
"""

import os

import numpy as np
import pytest
from scipy import sparse
from scipy.sparse import linalg

from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
from icidr_pde.cells import choice_asks
from icidr_pde.engines.choose import FOURIER_SOLVER, choose
from icidr_pde.engines.linear.xfourier_inverse import XFourierPreconditioner
from icidr_pde.cells.plane2d.scenes import Bump2DScene
from icidr_pde.validation import ParameterError

#: one worker under pytest-xdist: the preconditioner's kernels compile once, not on both workers at once
pytestmark = pytest.mark.xdist_group("xfourier")

#: gammas of CVODE's steps on the 2-D cell (0.01-0.2) and beyond, where the band LU pivots
GAMMAS = (0.01, 0.2, 2.0)


def _state(rheology, nx, nz, x_dependent):
    pde = ShearCell2DPDE(rheology)
    grid = pde.make_grid(None, 30.0, Nx=nx, Nz=nz)
    if x_dependent:
        return pde, pde.make_state(grid, *Bump2DScene(ell=4.0).initial_condition(pde.nodes(grid)))
    z = pde.nodes(grid)[..., 1]
    return pde, pde.make_state(grid, 0.78 + 0.01 * np.sin(z / 5), z / 30 + 0.02 * np.sin(z / 3),
                               0.01 * np.sin(np.pi * z / 30))


def _jacobian(pde, state):
    return sparse.csr_matrix(pde.make_jacobian(state)(0.0, state.data.ravel()))


def _newton(A, gamma):
    return sparse.csc_matrix(sparse.identity(A.shape[0]) - gamma * A)


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_exact_inverse_of_the_newton_matrix_on_a_state_independent_of_x(rheology):
    """x-independent phi, u, w (nx = 12, nz = 10, an odd number of x-modes beside the mean):
    z = P^-1 r solves (I - gamma J) z = r to round-off at every gamma, pivoting ones included."""
    pde, state = _state(rheology, 12, 10, x_dependent=False)
    J = _jacobian(pde, state)
    r = np.random.default_rng(1).standard_normal(J.shape[0])
    P = XFourierPreconditioner(J, state.data.shape, GAMMAS[0])
    for gamma in GAMMAS:
        P.at(gamma)
        z = P.solve(r)
        assert np.linalg.norm(_newton(J, gamma) @ z - r) < 1e-12 * np.linalg.norm(r), gamma


@pytest.mark.parametrize("nx", [8, 9])
def test_inverse_of_the_average_of_the_x_shifted_jacobians(nx):
    """On the x-dependent bump2d state, P^-1 = (I - gamma A)^-1 with A = (1/Nx) sum_s S^-s J S^s,
    S the shift by one column along the periodic x (even and odd Nx)."""
    pde, state = _state("icidr", nx, 7, x_dependent=True)
    J = _jacobian(pde, state)
    fields, _, nz = state.data.shape
    index = np.arange(J.shape[0]).reshape(fields, nx, nz)
    A = sparse.csr_matrix(J.shape)
    for s in range(nx):
        shift = np.roll(index, s, axis=1).ravel()
        A = A + J[shift][:, shift]
    A = A / nx
    assert abs(A - J).max() > 1e-3 * abs(J).max()  # the state depends on x: A is not J
    r = np.random.default_rng(2).standard_normal(J.shape[0])
    P = XFourierPreconditioner(J, state.data.shape, 0.2)
    expected = linalg.spsolve(_newton(A, 0.2), r)
    assert np.max(np.abs(P.solve(r) - expected)) < 1e-10 * np.max(np.abs(expected))


def test_the_solve_keeps_the_mass():
    """c P^-1 r = c r for c = 1 on phi (the mass): the x-average keeps c J = 0."""
    pde, state = _state("icidr", 16, 12, x_dependent=True)
    J = _jacobian(pde, state)
    c = np.zeros(J.shape[0])
    c[:16 * 12] = 1.0
    assert np.max(np.abs(c @ J)) < 1e-12 * abs(J).max()
    r = np.random.default_rng(3).standard_normal(J.shape[0])
    for gamma in GAMMAS:
        P = XFourierPreconditioner(J, state.data.shape, gamma)
        assert abs(c @ P.solve(r) - c @ r) < 1e-12 * np.sum(np.abs(r)), gamma


def _run(rheology, jacobian, n, t_end, times):
    from icidr_pde import run

    return run(rheology, "bump2d", (n, n), t_end, times, method="CVODE", rtol=1e-7, atol=1e-10,
               jacobian=jacobian, engine="pde")


def test_preconditioned_run_agrees_with_unpreconditioned_and_keeps_the_mass():
    """iCIDR bump2d 16^2 to t = 2 at rtol 1e-7: max|w| and the velocity norm of GMRES + x-Fourier
    equal those of GMRES without a preconditioner to 1e-5 relative (rtol-accurate solutions of
    one ODE); mass to round-off."""
    times = ["0.5", "1", "2"]
    fourier, plain = _run("icidr", "fourier", 16, 2.0, times), _run("icidr", "krylov", 16, 2.0, times)
    assert fourier.settings["linear_solver"] == FOURIER_SOLVER
    assert fourier.reason == plain.reason == "reached t_end"
    a, b = fourier.to_dict(), plain.to_dict()
    for q in ("max_w", "l2_velocity"):
        for t in times:
            assert a[q][t] == pytest.approx(b[q][t], rel=1e-5), (q, t)
    assert abs(fourier.mass_drift) < 1e-12


@pytest.mark.slow
def test_mui_failure_time_does_not_depend_on_the_preconditioner():
    """mu(I) bump2d 32^2 (ill-posed): t* of GMRES + x-Fourier equals that of GMRES alone at the
    same Krylov tolerance (0.806: docs/sim2d.md)."""
    stars = [_run("mui", jacobian, 32, 10.0, ["0", "10"]) for jacobian in ("fourier", "krylov")]
    assert all(r.blew_up for r in stars)
    assert stars[0].t_star == pytest.approx(stars[1].t_star, rel=1e-4)


def test_choice_and_refusals():
    """'fourier' is CVODE's on the 2-D cell's analytic sparse Jacobian only, and needs x periodic."""
    choice = choose(method="CVODE", jacobian="fourier", request="pde", **choice_asks("fv2d", request="pde"))
    assert (choice.engine, choice.jacobian, choice.linear_solver) == ("sundae", "fourier", FOURIER_SOLVER)
    with pytest.raises(ParameterError, match="fourier"):
        choose(method="CVODE", jacobian="fourier", request="pde", **choice_asks("cheb", request="pde"))
    with pytest.raises(ParameterError, match="jacobian"):
        choose(method="BDF", jacobian="fourier", **choice_asks("fv2d"))
    pde, state = _state("icidr", 8, 6, x_dependent=False)
    with pytest.raises(ParameterError, match="`J` must be"):
        XFourierPreconditioner(_jacobian(pde, state), (3, 8, 5), 0.1)


def test_band_solve_threads_wait_passively():
    """The x-Fourier module sets OpenMP's wait policy to passive before numba starts its threads
    (spinning threads took a loaded machine's cores: docs/scaling.md), and keeps a user's own."""
    import subprocess
    import sys

    child = ("import os\nfrom icidr_pde.engines.linear import xfourier_inverse\nprint(os.environ['OMP_WAIT_POLICY'])")
    for given, expected in ((None, "PASSIVE"), ("ACTIVE", "ACTIVE")):
        env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
        if given:
            env["OMP_WAIT_POLICY"] = given
        out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, env=env, check=True)
        assert out.stdout.strip() == expected
