"""The finite-volume scheme: truncation order and input errors (the contract: test_discretization_contract.py)."""

import numpy as np
import pytest
import sympy as sp

from icidr_pde import ShearCellPDE

H = 30.0


def sine_state(eq, N, a=0.16):
    g = eq.make_grid(N, H)
    return eq.make_state(
        g,
        lambda z: 0.78 + 0.01 * np.cos(3 * z / H),
        lambda z: z / H + a * np.sin(2 * np.pi * z / H),
        lambda z: -0.1 * np.sin(2 * np.pi * z / H + 0.1),  # no face with w = 0 exactly
    )


def exact_rates(rheology):
    """Continuous right-hand side of (3.13)-(3.15)/(5.3)-(5.5) for a manufactured state."""
    z = sp.symbols("z", real=True)
    phi = sp.Rational(78, 100) + sp.cos(3 * z / H) / 100
    u = z / H + sp.Rational(16, 100) * sp.sin(2 * sp.pi * z / H)
    w = -sp.sin(2 * sp.pi * z / H + sp.Rational(1, 10)) / 10
    from .test_rheology import shear_cell_stress, phi as s_phi, uz as s_uz, wz as s_wz
    from icidr_pde import Material

    p, txz, tzz = (e.subs({s_phi: phi, s_uz: sp.diff(u, z), s_wz: sp.diff(w, z)})
                   for e in shear_cell_stress(rheology, Material()))
    rates = [-sp.diff(phi * w, z),
             sp.diff(txz, z) / phi - w * sp.diff(u, z),
             sp.diff(tzz - p, z) / phi - w * sp.diff(w, z)]
    return [sp.lambdify(z, r, "numpy") for r in rates]


@pytest.mark.parametrize("advection, order", [("upwind", 1), ("central", 2)])
def test_truncation_error_order_interior(advection, order):
    """Manufactured solution: interior truncation error falls like h^order."""
    exact = exact_rates("icidr")
    errors = []
    for N in (40, 80, 160):
        eq = ShearCellPDE("icidr", advection=advection)
        state = sine_state(eq, N)
        rate = eq.evolution_rate(state).data[:, 2:-2]
        z = state.grid.axes_coords[0][2:-2]
        errors.append(max(np.max(np.abs(rate[k] - exact[k](z))) for k in range(3)))
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(observed > order - 0.2), observed


def test_invalid_inputs_raise_naming_parameter():
    with pytest.raises(ValueError, match="rheology"):
        ShearCellPDE("newtonian")
    with pytest.raises(ValueError, match="advection"):
        ShearCellPDE("icidr", advection="weno")
    with pytest.raises(ValueError, match="`N`"):
        ShearCellPDE.make_grid(2)
    with pytest.raises(ValueError, match="`H`"):
        ShearCellPDE.make_grid(10, -1.0)
