"""Abs, Max, Min and Piecewise in a law: the numba, numpy and C kernels equal sympy's own evaluation."""

import ctypes
import shutil
import subprocess

import numpy as np
import pytest
import sympy as sp

from icidr_pde.rheology import SHEAR_CELL, define_direct_law
from icidr_pde.rheology import symbols as s
from icidr_pde.rheology.ccode import UnsupportedLaw, c_law_source
from icidr_pde.rheology.cidr import LawError
from icidr_pde.rheology.codegen import generated_source, law_expressions

#: p with a kink in each of Abs, Max (three arguments), Min and a Piecewise; ||tau|| with Abs and Min
PRESSURE = sp.Max((s.norm_S / s.Psi) ** 2, sp.Abs(s.div_u) * s.norm_S, s.norm_S / 4) \
    + sp.Min(s.norm_S ** 2, sp.Abs(s.div_u) / 8) + sp.Piecewise((s.div_u ** 2, s.div_u > 0), (0, True))
SHEAR = s.M * s.norm_S * (sp.Abs(s.div_u) + sp.Min(s.norm_S, 1) + 1) / s.Psi
#: every other function a declarative law may use (:data:`~icidr_pde.rheology.declarative.FUNCTIONS`)
SMOOTH = (s.norm_S / s.Psi) ** 2 * (1 + sp.tanh(s.div_u) ** 2 + sp.exp(-s.phi) + sp.log(1 + s.phi)
                                    + sp.atan(s.div_u) ** 2 + sp.sinh(s.phi) / sp.cosh(s.phi) + sp.sqrt(s.phi))
LAWS = {"kinked-law": (PRESSURE, SHEAR), "smooth-law": (SMOOTH, s.M * SMOOTH)}

#: (phi, u_z, w_z): states on both sides of every kink (no ties, where sympy's Heaviside(0) = 1/2 is taken)
STATES = [(0.60, 0.3, 0.7), (0.70, 1.9, -0.4), (0.75, -0.05, 0.02), (0.62, 0.8, 0.9), (0.79, -2.5, -1.1)]


@pytest.fixture(scope="module", params=sorted(LAWS))
def kinked(request):
    cls = define_direct_law(request.param, *LAWS[request.param], register=False)
    return cls()


def test_every_function_of_the_declarative_format_is_tested():
    from icidr_pde.rheology.declarative import FUNCTIONS

    used = {type(a).__name__ for law in LAWS.values() for e in law for a in sp.preorder_traversal(e)}
    used |= {"sqrt"} if any(e.has(sp.sqrt(s.phi)) for law in LAWS.values() for e in law) else set()
    assert {attr for attr, *_ in FUNCTIONS.values()} <= used


def _truth(kinked):
    """Outputs and Jacobian entries evaluated by sympy at STATES (exact parameters, 30 digits)."""
    args, pnames, outputs, jac, _ = law_expressions(kinked, SHEAR_CELL)
    params = dict(zip(pnames, kinked.material.params))
    out = []
    for state in STATES:
        subs = {sp.Symbol(a, real=True): v for a, v in zip(args, state)}
        subs.update({sp.Symbol(k, real=True): v for k, v in params.items()})
        out.append([float(e.xreplace(subs).evalf(30)) for e in outputs + jac])
    return np.array(out), len(outputs)


def test_numba_and_numpy_kernels_are_sympys_evaluation(kinked):
    truth, n_out = _truth(kinked)
    k = kinked.kernels(SHEAR_CELL)
    params = kinked.material.params
    phi, uz, wz = (np.array(c) for c in zip(*STATES))
    numpy_form = np.column_stack(k.stress_numpy(phi, uz, wz, params) + k.stress_jacobian_numpy(phi, uz, wz, params))
    numba_form = np.array([k.stress(*st, params) + k.stress_jacobian(*st, params) for st in STATES])
    np.testing.assert_allclose(numpy_form, truth, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(numba_form, truth, rtol=1e-13, atol=1e-14)


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler")
def test_c_kernel_is_sympys_evaluation(kinked, tmp_path):
    truth, n_out = _truth(kinked)
    n_args = 3
    source = c_law_source(kinked, SHEAR_CELL) + (
        "\nvoid call(double phi, double uz, double wz, const double *params, double *out)\n"
        "{ law_stress(phi, uz, wz, params, out); law_stress_jacobian(phi, uz, wz, params, out + LAW_N_OUTPUTS); }\n")
    (tmp_path / "law.c").write_text(source)
    lib = tmp_path / "law.so"
    subprocess.run(["cc", "-O2", "-shared", "-fPIC", "-o", str(lib), str(tmp_path / "law.c"), "-lm"], check=True)
    call = ctypes.CDLL(str(lib)).call
    params = np.asarray(kinked.material.params, dtype=float)
    rows = []
    for state in STATES:
        out = np.zeros(n_out * (1 + n_args))
        call(*(ctypes.c_double(v) for v in state), params.ctypes.data_as(ctypes.c_void_p),
             out.ctypes.data_as(ctypes.c_void_p))
        rows.append(out)
    np.testing.assert_allclose(np.array(rows), truth, rtol=1e-13, atol=1e-14)


def test_a_function_no_printer_knows_is_a_law_error_naming_it():
    law = define_direct_law("bessel-law", (s.norm_S / s.Psi) ** 2 * (1 + sp.besselj(0, s.phi)),
                            s.M * (s.norm_S / s.Psi) ** 2, register=False)()
    with pytest.raises(LawError, match="law 'bessel-law': its numba/numpy kernels cannot be generated .*besselj"):
        generated_source(law, SHEAR_CELL)
    with pytest.raises(UnsupportedLaw, match="law 'bessel-law': its C kernels cannot be generated .*besselj"):
        c_law_source(law, SHEAR_CELL)       # the native engine then falls back to the numba path
