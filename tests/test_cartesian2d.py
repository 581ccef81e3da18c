"""The 2-D x-periodic finite-volume shear cell (fv2d) against independent truth.

* x-independent data: the rates, the Jacobian's action and a whole run equal those of
  the 1-D finite-volume scheme;
* a manufactured solution: the discrete operator converges to the exact 2-D right-hand
  side (derived by sympy from the same law) at the scheme's order;
* conservation: the discrete mass rate sums to zero; a run's mass drift is < 1e-12;
* the analytic Jacobian against finite differences, and inside its declared pattern.
"""

import numpy as np
import pytest

from icidr_pde.engines.colored_fd import colored_fd_jacobian
from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
from icidr_pde.cells.shear1d.fd import ShearCellPDE
from icidr_pde.cells.plane2d.scenes import Bump2DScene, Mode2DScene
from .oracles import oracle_rhs

#: one worker under pytest-xdist: the 2-D kernels of each law and advection compile once, not on both
#: workers at the same time
pytestmark = pytest.mark.xdist_group("cartesian2d")

H = L = 30.0


def _state(pde, grid, amp=1.0):
    """A smooth x-dependent state that satisfies the walls."""
    def phi(p):
        return 0.78 + amp * 0.01 * np.cos(2 * np.pi * p[..., 0] / L) * np.cos(np.pi * p[..., 1] / H)

    def u(p):
        return p[..., 1] / H + amp * 0.05 * np.sin(2 * np.pi * p[..., 1] / H) * np.cos(2 * np.pi * p[..., 0] / L)

    def w(p):
        return amp * 0.04 * np.sin(2 * np.pi * p[..., 1] / H) * np.sin(2 * np.pi * p[..., 0] / L + 0.3)

    return pde.make_state(grid, phi, u, w)


def _x_independent(data1d, nx):
    return np.ascontiguousarray(np.broadcast_to(data1d[:, None, :], (3, nx, data1d.shape[1])))


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_numba_equals_numpy(rheology, advection):
    pde = ShearCell2DPDE(rheology, advection=advection)
    grid = pde.make_grid((9, 7), H, L=L)
    state = _state(pde, grid)
    a = pde.make_rates(state)(state.data, 0.0)
    b = oracle_rhs(pde, state)(state.data, 0.0)
    assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a))


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_x_independent_rates_are_the_1d_rates(rheology, advection):
    fd = ShearCellPDE(rheology, advection=advection)
    g1 = fd.make_grid(12, H)
    z = fd.nodes(g1)
    s1 = fd.make_state(g1, 0.78 + 0.01 * np.cos(np.pi * z / H), z / H + 0.1 * np.sin(2 * np.pi * z / H),
                       0.05 * np.sin(2 * np.pi * z / H))
    r1 = oracle_rhs(fd, s1)(s1.data, 0.0)
    pde = ShearCell2DPDE(rheology, advection=advection)
    grid = pde.make_grid((5, 12), H, L=L)
    d2 = _x_independent(s1.data, 5)
    r2 = pde.make_rates(pde.make_state(grid, *d2))(d2, 0.0)
    scale = np.max(np.abs(r1))
    assert np.max(np.abs(r2 - r1[:, None, :])) <= 1e-13 * scale
    # the Jacobian maps x-independent perturbations as the 1-D one does
    J1 = fd.make_jacobian(s1)(0.0, s1.data.ravel()).toarray()
    J2 = pde.make_jacobian(pde.make_state(grid, *d2))(0.0, d2.ravel())
    v1 = np.random.default_rng(1).normal(size=s1.data.size)
    Jv2 = (J2 @ _x_independent(v1.reshape(3, -1), 5).ravel()).reshape(3, 5, 12)
    assert np.max(np.abs(Jv2 - (J1 @ v1).reshape(3, 1, 12))) <= 1e-12 * np.max(np.abs(J1 @ v1))


@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_x_independent_run_reproduces_the_1d_run(advection):
    from pde.solvers import Controller

    from icidr_pde.engines.stiff import StiffSolver

    fd = ShearCellPDE("icidr", advection=advection)
    g1 = fd.make_grid(16, H)
    z = fd.nodes(g1)
    zc = z - H / 2
    s1 = fd.make_state(g1, 0.78, z / H, 0.05 * zc * np.exp(-zc**2 / 9))
    pde = ShearCell2DPDE("icidr", advection=advection)
    grid = pde.make_grid((4, 16), H, L=L)
    s2 = pde.make_state(grid, *_x_independent(s1.data, 4))
    finals = []
    for eq, state in ((fd, s1), (pde, s2)):
        solver = StiffSolver(eq, method="BDF", rtol=1e-8, atol=1e-11, jacobian="analytic")
        finals.append(Controller(solver, t_range=(0.0, 2.0), tracker=None).run(state).data)
    assert np.max(np.abs(finals[1] - finals[0][:, None, :])) < 1e-9
    assert np.max(np.abs(finals[0][2])) > 1e-4  # the bump has not decayed to nothing


@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_mass_rate_sums_to_zero_and_run_conserves_mass(advection):
    from pde.solvers import Controller

    from icidr_pde.engines.stiff import StiffSolver

    pde = ShearCell2DPDE("icidr", advection=advection)
    grid = pde.make_grid((12, 10), H, L=L)
    state = _state(pde, grid)
    rate = pde.make_rates(state)(state.data, 0.0)
    assert abs(pde.integral(rate[0], grid)) < 1e-15 * pde.integral(np.abs(rate[0]), grid) * rate[0].size
    mass0 = pde.integral(state.data[0], grid)
    solver = StiffSolver(pde, method="BDF", rtol=1e-6, atol=1e-9, jacobian="analytic")
    final = Controller(solver, t_range=(0.0, 1.0), tracker=None).run(state).data
    assert abs(pde.integral(final[0], grid) - mass0) / mass0 < 1e-12
    assert np.max(np.abs(final[0] - state.data[0])) > 1e-6  # phi did evolve


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_analytic_jacobian_against_finite_differences(rheology, advection):
    pde = ShearCell2DPDE(rheology, advection=advection)
    grid = pde.make_grid((6, 5), H, L=L)
    state = _state(pde, grid)
    rhs = pde.make_rates(state)
    y = state.data.ravel().copy()
    J = pde.make_jacobian(state)(0.0, y).toarray()
    eps = 1e-6
    Jfd = np.empty_like(J)
    for k in range(y.size):
        dy = np.zeros_like(y)
        dy[k] = eps
        Jfd[:, k] = (rhs((y + dy).reshape(state.data.shape)) - rhs((y - dy).reshape(state.data.shape))).ravel() / (2 * eps)
    assert np.max(np.abs(J - Jfd)) <= 1e-6 * np.max(np.abs(J))
    P = pde.jacobian_sparsity(state).toarray()
    assert np.all(J[P == 0] == 0) and np.all(Jfd[P == 0] == 0)


def test_pattern_values_are_the_jacobian_in_csc_order():
    pde = ShearCell2DPDE("icidr")
    grid = pde.make_grid((6, 5), H, L=L)
    state = _state(pde, grid)
    jac = pde.make_jacobian(state)
    y = state.data.ravel()
    P = pde.jacobian_sparsity(state).astype(float)
    P.data[:] = jac.pattern_values(0.0, y)
    assert np.array_equal(P.toarray(), jac(0.0, y).toarray())


def test_colored_fd_jacobian_is_accurate_where_w_vanishes():
    """Well-scaled increments: accurate at steady shear (w = 0), where scipy's shrink."""
    pde = ShearCell2DPDE("icidr")
    grid = pde.make_grid((6, 6), H, L=L)
    state = pde.make_state(grid, *Bump2DScene(eps=0.0).initial_condition(pde.nodes(grid)))
    rhs = pde.make_rates(state)

    def fun(t, y):
        return rhs(y.reshape(state.data.shape), t).ravel()

    jac = colored_fd_jacobian(fun, pde.jacobian_sparsity(state), 1.0)
    y = state.data.ravel()
    J = pde.make_jacobian(state)(0.0, y).toarray()
    assert jac.n_colors < y.size / 3
    assert np.max(np.abs(jac(0.0, y).toarray() - J)) <= 1e-6 * np.max(np.abs(J))


def _exact_rates(rheology, advection):
    """Exact 2-D right-hand side of the manufactured fields of :func:`_state`, by sympy."""
    import sympy as sp

    from icidr_pde.rheology.kinematics import strain_rate

    x, z = sp.symbols("x z", real=True)
    phi = sp.Rational(78, 100) + sp.Rational(1, 100) * sp.cos(2 * sp.pi * x / L) * sp.cos(sp.pi * z / H)
    u = z / H + sp.Rational(5, 100) * sp.sin(2 * sp.pi * z / H) * sp.cos(2 * sp.pi * x / L)
    w = sp.Rational(4, 100) * sp.sin(2 * sp.pi * z / H) * sp.sin(2 * sp.pi * x / L + sp.Rational(3, 10))
    grad = sp.Matrix([[sp.diff(u, x), sp.diff(u, z)], [sp.diff(w, x), sp.diff(w, z)]])
    div, S, norm = strain_rate(grad)
    from icidr_pde.rheology import get_rheology

    p, c = get_rheology(rheology).symbolic_stress(phi, div, norm)
    sxx, sxz, szz = -p + c * S[0, 0], c * S[0, 1], -p + c * S[1, 1]
    r_phi = -sp.diff(phi * u, x) - sp.diff(phi * w, z)
    r_u = (sp.diff(sxx, x) + sp.diff(sxz, z)) / phi - u * sp.diff(u, x) - w * sp.diff(u, z)
    r_w = (sp.diff(sxz, x) + sp.diff(szz, z)) / phi - u * sp.diff(w, x) - w * sp.diff(w, z)
    return sp.lambdify((x, z), [r_phi, r_u, r_w], "numpy")


@pytest.mark.parametrize("rheology,advection,order", [("icidr", "central", 1.8), ("icidr", "upwind", 0.9),
                                                      ("mui", "central", 1.8)])
def test_manufactured_solution_convergence_order(rheology, advection, order):
    exact = _exact_rates(rheology, advection)
    errors = []
    sizes = (16, 32, 64)
    for n in sizes:
        pde = ShearCell2DPDE(rheology, advection=advection)
        grid = pde.make_grid(n, H, L=L)
        state = _state(pde, grid)
        xz = pde.nodes(grid)
        ref = np.array([np.broadcast_to(r, grid.shape) for r in exact(xz[..., 0], xz[..., 1])])
        rate = pde.make_rates(state)(state.data, 0.0)
        errors.append(max(np.max(np.abs(rate[k] - ref[k])) / np.max(np.abs(ref[k])) for k in range(3)))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > order), (errors, orders)


def test_scenes_are_as_specified():
    scene = Bump2DScene()
    assert (scene.eps, scene.ell, scene.L, scene.H, scene.phi0) == (0.05, 3.0, 30.0, 30.0, 0.78)
    xz = np.array([[15.0, 18.0], [15.0, 15.0], [0.0, 15.0]])
    phi, u, w = scene.initial_condition(xz)
    assert np.allclose(w, [0.05 * np.exp(-1.0), 0.0, 0.0]) and np.allclose(u, [0.6, 0.5, 0.5])
    mode = Mode2DScene(theta=30.0, k=1.0)
    kx, kz = mode.wave_vector()
    assert np.isclose(kx * L / (2 * np.pi), round(kx * L / (2 * np.pi))) and np.isclose(kz, 0.5)


@pytest.mark.parametrize("kwargs,match", [(dict(N=3), "N[xz]"), (dict(N=(8, 2)), "Nz"), (dict(N=8, L=-1.0), "L"),
                                          (dict(N=(1, 2, 3)), "pair")])
def test_bad_grid_input_names_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ShearCell2DPDE.make_grid(**kwargs)


def _mui_tstar(sizes):
    from icidr_pde import run

    return [run("mui", "bump2d", (n, n), 10.0, ["0", "10"], series_times=[], method="CVODE", rtol=1e-7,
                atol=1e-10) for n in sizes]


def test_mui_bump2d_fails_with_t_star_falling_while_the_1d_bump_decays():
    """Ill-posed in 2-D (Heyman et al. 2017): every grid fails, t* falls with N; the same
    perturbation made x-independent decays in the 1-D cell at these N (chi < 0 there)."""
    from icidr_pde import run

    sizes = (16, 24, 32)
    runs = _mui_tstar(sizes)
    assert all(r.blew_up for r in runs)
    t_star = [r.t_star for r in runs]
    assert all(a > b for a, b in zip(t_star, t_star[1:])), t_star
    for n in sizes:
        one_d = run("mui", Bump2DScene().x_independent(), n, 10.0, ["0", "10"], discretization="fd",
                    series_times=[], method="CVODE", rtol=1e-7, atol=1e-10)
        assert not one_d.blew_up and np.max(np.abs(one_d.final[2])) < 0.05 * 0.5


@pytest.mark.slow
def test_mui_bump2d_t_star_keeps_falling_to_128():
    runs = _mui_tstar((48, 64, 96, 128))
    t_star = [r.t_star for r in runs]
    assert all(r.blew_up for r in runs) and all(a > b for a, b in zip(t_star, t_star[1:])), t_star


def _icidr_measures(sizes, times=("0.5", "1", "2", "5", "10")):
    from icidr_pde import run

    out = []
    for n in sizes:
        r = run("icidr", "bump2d", (n, n), 10.0, list(times), method="CVODE", rtol=1e-7, atol=1e-10)
        assert not r.blew_up and abs(r.mass_drift) < 1e-12
        d = r.to_dict()
        out.append({(q, t): d[q][t] for q in ("max_w", "max_phi_dev", "l2_velocity") for t in times})
    return out


@pytest.mark.parametrize("sizes,quantities", [
    # at 16^2 (h = 1.9 against the bump's width 3) max|phi - phi0| and, with central advection,
    # max|w| at t = 1 (order 0.2 from 16, 32, 64) are not yet in the asymptotic range
    ((16, 32, 64), ("l2_velocity",)),
    pytest.param((32, 64, 128), ("max_w", "max_phi_dev", "l2_velocity"), marks=pytest.mark.slow)])
def test_icidr_bump2d_converges_under_refinement(sizes, quantities):
    """Successive differences of the measures at every time shrink as the grid doubles."""
    a, b, c = _icidr_measures(sizes)
    for key in a:
        if key[0] in quantities:
            assert abs(b[key] - c[key]) < 0.8 * abs(a[key] - b[key]), key
    if sizes[0] >= 32:  # the default (central) is second order: the velocity norm's differences
        for key in a:  # fall by more than 2^1.45 (order 1.5-1.65 measured; upwind 1.0-1.36)
            if key[0] == "l2_velocity":
                assert abs(b[key] - c[key]) < 2**-1.45 * abs(a[key] - b[key]), key


def test_2d_default_is_second_order_central_and_1d_stays_upwind():
    """fv2d defaults to central (second order, docs/sim2d.md); fd keeps the paper's upwind."""
    assert ShearCell2DPDE("icidr").advection == "central"
    assert ShearCellPDE("icidr").advection == "upwind"


def test_upwind_reproduces_the_first_order_study():
    """`advection='upwind'` still gives the first-order study of data/sim2d/convergence_upwind.json
    (``icidr-pde study sim2d convergence --advection upwind``)."""
    import json
    import pathlib

    from icidr_pde import run

    path = pathlib.Path(__file__).resolve().parents[1] / "data" / "sim2d" / "convergence_upwind.json"
    study = json.loads(path.read_text())
    times = study["times"]
    settings = dict(study["settings"])
    assert settings.pop("advection") == "upwind"
    d = run("icidr", "bump2d", (16, 16), float(times[-1]), times, advection="upwind", engine="pde", jacobian="krylov",
            **settings).to_dict()  # the study's solver: the py-pde path's unpreconditioned GMRES at its
    # Krylov tolerance (the native one agrees to ~1e-8, the x-Fourier preconditioned one to ~1e-7: rtol)
    for q in ("max_w", "max_phi_dev", "l2_velocity"):
        for t in times:
            assert d[q][t] == pytest.approx(study["runs"]["16"][q][t], rel=1e-9), (q, t)
    default = run("icidr", "bump2d", (16, 16), float(times[-1]), times, **settings).to_dict()
    assert abs(default["max_w"]["10"] / d["max_w"]["10"] - 1) > 0.1  # the default is not upwind


def test_krylov_solves_of_2d_runs_use_the_tight_tolerance(monkeypatch):
    """CVODE's GMRES runs at eps_lin = KRYLOV_EPS_LIN (5e-5), not SUNDIALS' 0.05: the tighter
    linear solves need more Jacobian-vector products (difference quotients, one RHS call each)."""
    from icidr_pde import run
    from icidr_pde.engines import sundae as integrator

    def n_rhs():
        return run("mui", "bump2d", (16, 16), 0.5, ["0", "0.5"], series_times=[], method="CVODE",
                   jacobian="krylov", rtol=1e-7, atol=1e-10, engine="pde").to_dict()["n_rhs"]

    assert integrator.KRYLOV_EPS_LIN == 5e-5
    tight = n_rhs()
    monkeypatch.setattr(integrator, "KRYLOV_EPS_LIN", 0.05)
    assert tight > 1.1 * n_rhs()


def _bump2d(pde, shape, sign_changes=False):
    """The bump2d state on `shape`; with `sign_changes`, u shifted to change sign and phi
    perturbed cell by cell, so that every upwind branch is taken."""
    scene = Bump2DScene()
    grid = pde.make_grid(shape, scene.H, L=scene.L)
    state = pde.make_state(grid, *scene.initial_condition(pde.nodes(grid)))
    if sign_changes:
        state.data[1] -= 0.5
        state.data[0] += 0.01 * np.sin(np.arange(state.data[0].size)).reshape(grid.shape)
    return state


@pytest.mark.parametrize("shape", [(32, 32), (16, 24)])
@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_whole_grid_rates_through_the_patch_kernel_equal_the_oracle(shape, rheology, advection):
    pde = ShearCell2DPDE(rheology, advection=advection)
    for sign_changes in (False, True):
        state = _bump2d(pde, shape, sign_changes)
        a = pde.make_rates(state)(state.data, 0.0)
        b = oracle_rhs(pde, state)(state.data, 0.0)
        assert np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(a))


def _patch(data, xs, zs):
    """The block data[:, xs, zs] with one ghost layer, filled from the whole state as a
    distributed array's local part is: x ghosts periodic, z ghosts from the neighbouring
    rows, NaN beyond a wall (the patch kernel must fill those rows itself)."""
    nz = data.shape[2]
    cols = np.arange(xs.start - 1, xs.stop + 1) % data.shape[1]
    rows = np.arange(zs.start - 1, zs.stop + 1)
    g = np.full((3, cols.size, rows.size), np.nan)
    inside = (rows >= 0) & (rows < nz)
    g[:, :, inside] = data[:, cols][:, :, rows[inside]]
    return g, zs.start == 0, zs.stop == nz


@pytest.mark.parametrize("shape,x_split,z_split", [((32, 32), 16, 16), ((16, 24), 7, 13)])
@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_patches_of_a_split_grid_give_the_whole_grid_rates(shape, x_split, z_split, rheology, advection):
    pde = ShearCell2DPDE(rheology, advection=advection)
    state = _bump2d(pde, shape, sign_changes=True)
    whole = pde.make_rates(state)(state.data, 0.0)
    patches = pde.patches(state)
    assert patches.shape == shape and patches.dof == 3 and patches.periodic == (True, False)
    nx, nz = shape
    covered = np.zeros(shape, bool)
    for xs in (slice(0, x_split), slice(x_split, nx)):
        for zs in (slice(0, z_split), slice(z_split, nz)):
            g, low, high = _patch(state.data, xs, zs)
            out = np.empty((3, xs.stop - xs.start, zs.stop - zs.start))
            patches.rates(g, low, high, out)
            assert np.array_equal(out, whole[:, xs, zs])
            covered[xs, zs] = True
    assert covered.all()


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_patch_jacobians_of_a_split_grid_are_the_whole_grid_jacobian_rows(rheology, advection):
    pde = ShearCell2DPDE(rheology, advection=advection)
    shape, x_split, z_split = (16, 24), 7, 13
    state = _bump2d(pde, shape, sign_changes=True)
    J = pde.make_jacobian(state)(0.0, state.data.ravel()).toarray()
    patches = pde.patches(state)
    nx, nz = shape
    index = np.arange(state.data.size).reshape(state.data.shape)
    rows_done = []
    for xs in (slice(0, x_split), slice(x_split, nx)):
        for zs in (slice(0, z_split), slice(z_split, nz)):
            g, low, high = _patch(state.data, xs, zs)
            Jp = patches.jacobian(g, low, high).toarray()
            # the patch's values: periodic columns, rows beyond a wall have no unknown (-1)
            cols = np.arange(xs.start - 1, xs.stop + 1) % nx
            zrows = np.arange(zs.start - 1, zs.stop + 1)
            unknown = np.full(g.shape, -1)
            inside = (zrows >= 0) & (zrows < nz)
            unknown[:, :, inside] = index[:, cols][:, :, zrows[inside]]
            unknown = unknown.ravel()
            assert np.all(Jp[:, unknown < 0] == 0)
            rows = index[:, xs, zs].ravel()
            whole = np.zeros_like(Jp)
            whole[:, unknown >= 0] = J[np.ix_(rows, unknown[unknown >= 0])]
            # (an unknown is one column of the patch here: no block spans the whole periodic x)
            assert np.max(np.abs(Jp - whole)) <= 1e-14 * np.max(np.abs(J))
            rows_done.append(rows)
    assert np.array_equal(np.sort(np.concatenate(rows_done)), np.arange(J.shape[0]))
