"""The discretization contract (icidr_pde.discretizations.base), checked for every registered
scheme: the steady shear fixed point (3.10), compiled kernels = independent numpy code, mass
conservation, the analytic Jacobian against finite differences, its sparsity and band, and
the validity checks. A new discretization gets these tests by registering itself."""

import numpy as np
import pytest
from pde.pdes.base import PDEBase

from icidr_pde.discretizations import DISCRETIZATIONS, ShearCellBase
from icidr_pde.rheology import Material

from .oracles import oracle_rhs

H = 30.0
SCHEMES = sorted(DISCRETIZATIONS)
LAWS = {"table1": Material(), "saturating": Material(dilatancy="saturating")}


def coordinates(pde, grid):
    """(x, z) of the unknowns: x = 0 in the 1-D cell; nodes are grid.shape or (*grid.shape, dim)."""
    nodes = pde.nodes(grid)
    if nodes.ndim == len(grid.shape):
        return np.zeros(grid.shape), nodes
    return nodes[..., 0], nodes[..., -1]


def perturbed_state(pde, N, a=0.1, seed=0):
    """A generic smooth state with u_z > 0 (mu(I) is smooth there) and no node with w = 0
    (varying along x too on a 2-D grid)."""
    grid = pde.make_grid(N, H)
    x, z = coordinates(pde, grid)
    rng = np.random.default_rng(seed)
    k = rng.uniform(0.5, 1.5, 3)
    bump = np.sin(np.pi * z / H) * (1 + 0.3 * np.cos(2 * np.pi * x / grid.axes_bounds[0][1] + k[1]))
    state = pde.make_state(grid, 0.78 + 0.01 * np.cos(k[0] * z / H) * (1 + np.sin(2 * np.pi * x / H)),
                           z / H + a * np.sin(2 * np.pi * z / H) * bump,
                           -0.1 * np.sin(2 * np.pi * z / H + 0.1) * bump + 0.002 * k[2] * bump)
    return grid, state


def central_differences(f, y, rel_step=1e-6):
    """Jacobian of f at y by central differences with steps rel_step * max(1, |y_k|)."""
    cols = []
    for k in range(y.size):
        h = rel_step * max(1.0, abs(y[k]))
        yp, ym = y.copy(), y.copy()
        yp[k] += h
        ym[k] -= h
        cols.append((f(yp) - f(ym)) / (2 * h))
    return np.column_stack(cols)


def small_N(cls):
    return {"fd": 24, "fv2d": 8}.get(cls.name, 13)


@pytest.fixture(params=SCHEMES)
def scheme(request):
    return DISCRETIZATIONS[request.param]


def scheme_and_law():
    """Every scheme with every law, for mu(I) and iCIDR; the second law compiles a kernel set of its
    own (10-16 s per scheme on 2 cores, ~4 s per rheology on fd), so the default run checks it for
    iCIDR on fd and the slow run for both rheologies on every scheme."""
    return pytest.mark.parametrize("rheology, scheme, law", [
        pytest.param(rheology, name, law, id=f"{rheology}-{name}-{law}",
                     marks=pytest.mark.slow if law != "table1" and (name != "fd" or rheology != "icidr") else ())
        for rheology in ("mui", "icidr") for name in SCHEMES for law in sorted(LAWS)], indirect=["scheme"])


def test_registry_and_declarations(scheme):
    assert issubclass(scheme, ShearCellBase) and issubclass(scheme, PDEBase)
    assert scheme.name in DISCRETIZATIONS and scheme.default_N >= 4
    for key, valid in scheme.options.items():
        assert len(valid) >= 1
        pde = scheme("icidr", **{key: valid[-1]})
        assert getattr(pde, key) == valid[-1] and pde.option_values()[key] == valid[-1]
        with pytest.raises(ValueError, match=key):
            scheme("icidr", **{key: "no-such-value"})
    with pytest.raises(ValueError, match="unknown option"):
        scheme("icidr", no_such_option=1)
    with pytest.raises(ValueError, match="rheology"):
        scheme("newtonian")
    with pytest.raises(ValueError, match="`N`"):
        scheme.make_grid(2)


#: the methods every scheme implements (the abstract methods of the contract, docstring of its module)
CONTRACT = {"nodes", "make_state", "integral", "strain_rates", "make_rates", "make_jacobian", "jacobian_sparsity",
            "interleaving"}


def test_the_contract_is_abstract_methods():
    """A scheme that lacks a method of the contract cannot be built: the error names the method."""
    assert ShearCellBase.__abstractmethods__ >= CONTRACT

    class Incomplete(ShearCellBase):
        def nodes(self, grid):
            return np.zeros(grid.shape)

    with pytest.raises(TypeError, match="make_jacobian"):
        Incomplete("icidr")


def test_every_scheme_implements_the_contract(scheme):
    assert not scheme.__abstractmethods__, f"{scheme.name} lacks {sorted(scheme.__abstractmethods__)}"
    for method in CONTRACT:
        assert getattr(scheme, method) is not getattr(ShearCellBase, method), f"{scheme.name}: {method}"
    for method in ("check_state", "validity_margins"):  # the validity checks, from the cores' phi range
        assert callable(getattr(scheme, method))


@pytest.mark.parametrize("rheology", ["mui", "icidr"])
def test_steady_linear_shear_is_a_fixed_point(scheme, rheology):
    """(3.10): phi = phi0, u = z/H, w = 0 solves the equations; both implementations keep it."""
    pde = scheme(rheology)
    grid = pde.make_grid(small_N(scheme) + 10, H)
    state = pde.make_state(grid, 0.78, coordinates(pde, grid)[1] / H, 0.0)
    for rate in (pde.evolution_rate(state).data, pde.make_rates(state)(state.data, 0.0)):
        assert np.max(np.abs(rate)) < 1e-12


@scheme_and_law()
def test_compiled_kernels_equal_numpy_implementation(scheme, rheology, law):
    pde = scheme(rheology, LAWS[law])
    _, state = perturbed_state(pde, 17 if getattr(scheme, "dim", 1) == 2 else 31)
    numpy_rate = oracle_rhs(pde, state)(state.data, 0.0)
    compiled = pde.make_rates(state)(state.data, 0.0)
    py_pde_numba = pde.make_pde_rhs(state, backend="numba")(state.data, 0.0)
    scale = np.max(np.abs(numpy_rate))
    np.testing.assert_allclose(compiled, numpy_rate, rtol=1e-12, atol=1e-13 * scale)
    np.testing.assert_allclose(py_pde_numba, compiled, rtol=1e-12, atol=1e-13 * scale)


@pytest.mark.parametrize("rheology", ["mui", "icidr"])
def test_mass_is_conserved(scheme, rheology):
    """d/dt of the scheme's integral of phi is -[phi w]_0^H = 0 (w = 0 at the walls)."""
    pde = scheme(rheology)
    grid, state = perturbed_state(pde, 40)
    rate = pde.make_rates(state)(state.data, 0.0)[0]
    assert abs(pde.integral(rate, grid)) < 1e-14 * pde.integral(np.abs(rate), grid) * rate.size


@scheme_and_law()
def test_jacobian_against_finite_differences(scheme, rheology, law):
    options = [dict(zip(scheme.options, values)) for values in
               (zip(*scheme.options.values()) if scheme.options else [()])]
    for opts in options or [{}]:
        pde = scheme(rheology, LAWS[law], **opts)
        N = small_N(scheme)
        _, state = perturbed_state(pde, N, seed=1)
        rhs = oracle_rhs(pde, state)
        y = state.data.ravel().copy()
        J_fd = central_differences(lambda v: rhs(v.reshape(state.data.shape), 0.0).ravel(), y)
        J = pde.make_jacobian(state)(0.0, y)
        J = J.toarray() if hasattr(J, "toarray") else np.asarray(J)
        assert np.max(np.abs(J - J_fd)) < 1e-6 * np.max(np.abs(J_fd)), opts
        pattern = pde.jacobian_sparsity(state)
        if pattern is not None:
            assert not np.any(J[~(pattern.toarray() != 0)])  # the pattern covers the Jacobian
        ordering = pde.interleaving(state)
        if ordering is not None:
            perm, lband, uband = ordering
            rows, cols = np.nonzero(J[np.ix_(perm, perm)])
            assert np.all(cols - rows <= uband) and np.all(rows - cols <= lband)


def test_nodes_state_strain_rates_and_validity(scheme):
    pde = scheme("icidr")
    grid, state = perturbed_state(pde, small_N(scheme))
    nodes = pde.nodes(grid)
    assert state.data.shape == (len(pde.fields), *grid.shape) and nodes.shape[:len(grid.shape)] == grid.shape
    assert pde.integral(np.ones(grid.shape), grid) == pytest.approx(grid.volume, rel=1e-12)
    pos, phi, *rates = pde.strain_rates(state.data, grid)
    assert len(rates) == len(pde.kinematics.rates)
    assert all(np.shape(r) == np.shape(pos)[:np.ndim(phi)] == np.shape(phi) for r in rates)
    assert pde.check_state(state.data) is None and np.all(pde.validity_margins(state.data) > 0)
    bad = state.data.copy()
    bad[0].flat[2] = pde.material.phi_c + 0.01
    assert "phi" in pde.check_state(bad) and pde.validity_margins(bad).min() < 0


@pytest.mark.parametrize("V0", [1.0, 0.37])
def test_fd_walls_are_py_pdes_boundary_conditions(V0):
    """The core's ghost maps (3.9) are what py-pde's own boundary setters of the adapter's
    conditions do, and its nodes are py-pde's cell centres."""
    from icidr_pde.cells.shear1d.fd import ShearCellPDE

    from .oracles.fd import setter_ghost_coefficients

    pde = ShearCellPDE("mui", V0=V0)
    grid = pde.make_grid(37, 30.0)
    assert np.array_equal(pde.ghost_coefficients(grid), setter_ghost_coefficients(pde, grid))
    assert np.array_equal(pde.nodes(grid), grid.axes_coords[0])


def test_registry_is_readable_without_py_pde():
    import subprocess
    import sys

    code = ("import sys; from icidr_pde.discretizations import SCHEMES, DISCRETIZATIONS; "
            "from icidr_pde.case import build_case; c = build_case('mui', 'shear', 'cheb', 9); "
            "print(sorted(SCHEMES), c.mass(), 'pde' in sys.modules, 'scipy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[-2:] == ["False", "False"]


@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_fd_jacobian_of_the_compiled_kernel_is_the_oracles(advection):
    """The scipy path's sparse fd Jacobian (the compiled band kernel's entries in the block
    ordering) is the chain rule of the independent numpy oracle, to round-off."""
    from icidr_pde.cells.shear1d.fd import ShearCellPDE

    from .oracles.fd import fd_jacobian

    pde = ShearCellPDE("icidr", advection=advection)
    grid, state = perturbed_state(pde, 23, seed=2)
    y = state.data.ravel()
    J = pde.make_jacobian(state)(0.0, y).toarray()
    oracle = fd_jacobian(pde, grid)(0.0, y).toarray()
    assert np.max(np.abs(J - oracle)) <= 1e-13 * np.max(np.abs(oracle))
