"""The C that icidr_pde.native.translate prints from a scheme's numba template.

Against independent truth: numba compiling the same template (the py-pde path's kernels,
themselves tested against exact solutions, fourth-order differences and conservation); the
C must compute the same numbers to the last bits in which the law's two printings (libm's
pow and numba's) and two OpenBLAS builds (Chebyshev's products with D) differ. Unsupported
Python is refused with the line named.
"""

import numpy as np
import pytest

from icidr_pde.native import NativeUnavailable
from icidr_pde.native_case import ChebCase, FdCase
from icidr_pde.native.translate import translate

#: one worker under pytest-xdist: each law's numba kernels, the reference of the C text, compile once,
#: not on both workers at the same time
pytestmark = pytest.mark.xdist_group("native_translate")

try:
    FdCase("icidr", "shear", 9).problem()
except NativeUnavailable as err:  # no gcc or no SUNDIALS libraries: the py-pde path is tested elsewhere
    pytest.skip(f"native engine unavailable: {err}", allow_module_level=True)


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_fd_c_is_the_numba_template(rheology, advection):
    from icidr_pde.case import build_case

    N = 41
    c = build_case(rheology, "sine", "fd", N, options=dict(advection=advection))
    problem = FdCase(rheology, "sine", N, advection=advection).problem()
    perm = c.pde.interleaving(c.state)[0]
    rhs, jac = c.pde.make_rates(c.state), c.pde.make_band_jacobian(c.state)
    rng = np.random.default_rng(3)
    for trial in range(4):
        data = c.state.data + (0.02 * trial) * rng.standard_normal(c.state.data.shape)
        data[0] = np.clip(data[0], 0.5, 0.8)
        y = data.ravel()[perm]
        expected = rhs(data).ravel()[perm]
        assert np.max(np.abs(problem.rates(y) - expected)) <= 1e-13 * np.max(np.abs(expected))
        J = np.zeros((3 * N, 3 * N))
        jac(y, J)
        assert np.max(np.abs(problem.jacobian_dense(y) - J)) <= 1e-13 * np.max(np.abs(J))


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("N", [17, 201])
def test_cheb_c_is_the_numba_template(rheology, N):
    from icidr_pde.case import build_case

    c = build_case(rheology, "sine", "cheb", N)
    case = ChebCase(rheology, "sine", N)
    problem = case.problem()
    rhs, jacobian = c.pde.make_rates(c.state), c.scheme.loops().jacobian
    D, params = c.pde.operators(c.grid)[1], c.pde.material.params
    rng = np.random.default_rng(5)
    for trial in range(3):
        data = case.fields(case.y0).copy()
        data[0] += 0.005 * rng.standard_normal(N)
        data[1:, 1:-1] += 0.05 * rng.standard_normal((2, N - 2))
        y = data.ravel()
        theirs, mine = rhs(data), problem.rates(y).reshape(3, N)
        for k in range(3):  # sums of D times a field: to the BLAS builds' last bits
            assert np.max(np.abs(mine[k] - theirs[k])) <= 1e-14 * np.max(np.abs(theirs[k])), k
        J_ref = np.empty((3 * N, 3 * N))
        jacobian(data, D, params, J_ref)
        J = problem.jacobian_dense(y)
        assert np.max(np.abs(J - J_ref)) <= 1e-13 * np.max(np.abs(J_ref))
        walls = [N, 2 * N - 1, 2 * N, 3 * N - 1]
        assert np.all(J[walls] == 0) and np.all(problem.rates(y)[walls] == 0)


@pytest.mark.parametrize("body, what", [
    ("    x[0:2] = 1.0", "slices"),
    ("    x[0] = 1.0 if n else 2", "holds an int and a double"),
    ("    for i in range(0, n, 2):\n        x[i] = 0.0", "range with a step"),
    ("    x[0] = sum(x)", "not in the subset"),
])
def test_unsupported_python_is_refused_with_its_line(body, what):
    source = f'def f(x: "float64[:]", n: "int64"):\n    y = 0\n{body}\n'
    if "holds" in what:
        source = 'def f(x: "float64[:]", n: "int64"):\n    y = 0\n    y = 1.5\n'
    with pytest.raises(SyntaxError, match=f"line 3: .*{what}" if "holds" not in what else what):
        translate(source, "t_")


def test_parameters_need_their_numba_types():
    with pytest.raises(SyntaxError, match="line 1: parameters need a numba type string"):
        translate("def f(x):\n    pass\n", "t_")
