"""The Jacobian-vector product of CVODE's GMRES on the 2-D cell (engines.jacobian_vector)."""

import numpy as np

from icidr_pde.engines.jacobian_vector import INCREMENT, difference_jtimes


def _product(fun_into, y, v):
    jtimes = difference_jtimes(fun_into, y.size).solvefn
    fy, Jv = np.empty(y.size), np.empty(y.size)
    fun_into(0.0, y, fy)
    jtimes(0.0, y, fy, v, Jv)
    return Jv


def test_exact_on_a_linear_right_hand_side():
    rng = np.random.default_rng(1)
    A = rng.standard_normal((40, 40))

    def fun_into(t, y, out):
        out[:] = A @ y

    y, v = rng.standard_normal(40), rng.standard_normal(40)
    assert np.allclose(_product(fun_into, y, v), A @ v, rtol=1e-7, atol=1e-7 * np.abs(A @ v).max())


def test_first_order_accurate_on_a_nonlinear_one():
    """f = y^3 (J = 3 y^2): the quotient's error is 3 y sigma v^2, below INCREMENT-scaled bounds."""
    rng = np.random.default_rng(2)
    y, v = 1.0 + rng.random(30), rng.standard_normal(30) * 1e-3  # a small v: sigma v is still INCREMENT-sized

    def fun_into(t, x, out):
        out[:] = x**3

    exact = 3 * y**2 * v
    error = np.abs(_product(fun_into, y, v) - exact).max() / np.abs(exact).max()
    assert error < 1e-5
    assert error > 0  # a difference quotient, not the exact product


def test_zero_vector_gives_zero_without_a_call():
    calls = []

    def fun_into(t, y, out):
        calls.append(1)
        out[:] = y

    y = np.ones(5)
    jtimes = difference_jtimes(fun_into, 5).solvefn
    Jv = np.full(5, np.nan)
    jtimes(0.0, y, y.copy(), np.zeros(5), Jv)
    assert np.all(Jv == 0) and not calls


def test_perturbation_size():
    """max |sigma v| = INCREMENT max(1, max |y|): the perturbed state the right-hand side sees."""
    seen = []

    def fun_into(t, y, out):
        seen.append(y.copy())
        out[:] = 0.0

    y, v = np.array([0.5, -20.0, 3.0]), np.array([1e-3, 2e-3, -4e-3])
    jtimes = difference_jtimes(fun_into, 3).solvefn
    jtimes(0.0, y, np.zeros(3), v, np.empty(3))
    assert np.isclose(np.abs(seen[0] - y).max(), INCREMENT * 20.0, rtol=1e-9)
