"""Item 7: the numbers of `stability` against direct numpy eigenvalues."""

import numpy as np
import pytest

from .conftest import ILL_POSED
from stability.numeric import A_matrix, coefficients, gamma, stability_numbers


def _sim_coefficients(name, ph, u, w, h=1e-6):
    """a_i, b_ij from central differences of the simulator's stress (independent of sympy)."""
    import icidr_pde.rheology as rheo
    sim = rheo.get_rheology(name)

    def F(a, b, c):
        p, txz, tzz = sim.stress(a, b, c)
        return np.array([txz, tzz - p], float)

    dphi = (F(ph + h, u, w) - F(ph - h, u, w)) / (2 * h) / ph
    du = (F(ph, u + h, w) - F(ph, u - h, w)) / (2 * h) / ph
    dw = (F(ph, u, w + h) - F(ph, u, w - h)) / (2 * h) / ph
    return {"a1": dphi[0], "a2": dphi[1], "b11": du[0], "b12": dw[0], "b21": du[1], "b22": dw[1]}


@pytest.mark.parametrize("name", ["mui", "icidr"])
@pytest.mark.parametrize("state", [ILL_POSED, {"phi": 0.7, "uz": 0.2, "wz": -0.1}, {"phi": 0.81, "uz": -1.0, "wz": 0.3}])
def test_item7_numbers_against_numpy(name, state):
    ph, u, w = state["phi"], state["uz"], state["wz"]
    xi = 1e4
    sn = stability_numbers(name, ph, u, w, xi)
    c = _sim_coefficients(name, ph, u, w)
    for k, v in coefficients(name, ph, u, w).items():
        assert v == pytest.approx(c[k], rel=1e-5, abs=1e-7 * max(abs(x) for x in c.values()))
    G = gamma(c)
    assert sn.trace_gamma == pytest.approx(np.trace(G), rel=1e-5)
    assert sn.det_gamma == pytest.approx(np.linalg.det(G), rel=1e-5)
    lam = np.sort(np.linalg.eigvals(-G).real)           # Lambda = eig(-Gamma)
    assert sn.lambda_plus.real == pytest.approx(lam[1], rel=1e-5)
    assert sn.lambda_minus.real == pytest.approx(lam[0], rel=1e-5)
    assert sn.lambda_plus.real >= sn.lambda_minus.real
    ev = np.linalg.eigvals(A_matrix(c, ph, xi))
    assert sn.max_re_eig_over_xi2 == pytest.approx(ev.real.max() / xi**2, rel=1e-5, abs=1e-12)
    # the bounded eigenvalue at very large xi approaches -C/B
    ev = np.linalg.eigvals(A_matrix(c, ph, 1e6))
    lam0 = ev[np.argmin(np.abs(ev))].real
    assert sn.lambda0_limit == pytest.approx(lam0, rel=1e-4)
    # chi is the mu(I) indicator of (A18) at this state
    M = sn.M
    assert sn.chi == pytest.approx(w / abs(u) - M / np.sqrt(1 - M**2))


def test_ill_posed_example_of_issue():
    mui = stability_numbers("mui", **ILL_POSED)
    ic = stability_numbers("icidr", **ILL_POSED)
    assert mui.chi > 0 and mui.lambda_plus.real > 0 and mui.det_gamma < 0
    assert ic.lambda_plus.real < 0 and ic.det_gamma > 0 and ic.trace_gamma > 0
    assert abs(ic.max_re_eig_over_xi2) < 1e-6


@pytest.mark.parametrize("kw,match", [({"phi": 0.9}, "phi"), ({"phi": 0.0}, "phi"), ({"xi": -1.0}, "xi"),
                                      ({"xi": 0.0}, "xi"), ({"uz": float("nan")}, "uz"),
                                      ({"uz": 0.0, "wz": 0.0}, "uz")])
def test_bad_input_raises_value_error(kw, match):
    args = {"name": "icidr", "phi": 0.78, "uz": 0.1, "wz": 0.1, "xi": 1e4}
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        stability_numbers(**args)
