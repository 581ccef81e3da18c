"""The time integration of the 2-D cell is stable by construction (issue 37).

Independent truths: the stability regions of the BDF formulas (their boundary locus, computed
here from the formulas' coefficients), the exact solution of linear advection with damping (each
discrete Fourier mode decays as exp(-d t)), and the continuum's linear rates of iCIDR's x-waves,
about -0.03 for every wave number (a short wave that grows in a run is the integrator's).
"""

from math import comb

import numpy as np
import pytest
from scipy import sparse

from icidr_pde.engines.base import JacobianSpec, Problem
from icidr_pde.cells import choice_asks
from icidr_pde.engines.choose import (A_STABLE_ORDER, BDF_MAX_ORDER, JacobianStructure, choose,
                                      time_order)
from icidr_pde.validation import ParameterError


def bdf_alpha(order: int) -> float:
    """The angle alpha (degrees) of BDF-`order`'s A(alpha)-stability: the stability region holds the
    sector |arg(-z)| < alpha. From the boundary locus z(theta) = rho(e^{i theta}) / sigma(e^{i theta}),
    rho(zeta) = sum_{j=1..k} (1/j) zeta^{k-j} (zeta - 1)^j, sigma(zeta) = zeta^k."""
    theta = np.linspace(1e-4, np.pi, 200_001)
    zeta = np.exp(1j * theta)
    rho = sum((zeta - 1) ** j * zeta ** (order - j) / j for j in range(1, order + 1))
    z = rho / zeta**order
    left = z.real < 0
    if not left.any():
        return 90.0
    return float(np.degrees(np.min(np.abs(np.arctan2(z.imag[left], -z.real[left])))))


def test_bdf_stability_angles_are_the_textbook_ones():
    """The locus gives Hairer & Wanner's angles (BDF3-5: 86.03, 73.35, 51.84 degrees) and A-stability
    up to order 2, the order the 2-D cell's default takes."""
    assert [round(bdf_alpha(k), 1) for k in (3, 4, 5)] == [86.0, 73.4, 51.8]
    assert bdf_alpha(1) == bdf_alpha(A_STABLE_ORDER) == 90.0


def _spectrum_angle(jac_dense: np.ndarray) -> float:
    """The largest angle (degrees) between an eigenvalue of the Jacobian and the negative real axis."""
    lam = np.linalg.eigvals(jac_dense)
    lam = lam[np.abs(lam) > 1e-6 * np.abs(lam).max()]  # not the conserved mass's zero, nor its round-off
    assert lam.real.max() < 0  # iCIDR: every mode decays
    return float(np.degrees(np.max(np.arctan2(np.abs(lam.imag), -lam.real))))


def test_1d_spectrum_lies_inside_bdf5_sector():
    """The 1-D cell (iCIDR, scene sine at t = 20, N = 47): every eigenvalue of the Jacobian lies
    inside BDF5's stability sector, so the 1-D default keeps orders up to 5 (the regression anchors)."""
    from icidr_pde import run
    from icidr_pde.case import build_case

    res = run("icidr", "sine", N=47, t_end=20, times=[0, 20], series_times=[])
    case = build_case("icidr", "sine", "fd", 47)
    y = np.array(res.final).ravel()
    J = case.pde.make_jacobian(case.state)(20.0, y).toarray()
    assert _spectrum_angle(J) < bdf_alpha(BDF_MAX_ORDER) - 3
    assert res.settings["max_order"] == BDF_MAX_ORDER


def test_2d_spectrum_leaves_bdf5_sector():
    """The 2-D cell (iCIDR bump2d 16^2 at t = 2): advection along x puts eigenvalues outside the
    sectors of BDF5 and BDF4 (finer grids, nearer the imaginary axis: BDF3 amplified a band at 256^2,
    issue 37): why its default is the A-stable order."""
    from icidr_pde import run
    from icidr_pde.case import build_case

    res = run("icidr", "bump2d", (16, 16), 2.0, ["2"], series_times=[])
    case = build_case("icidr", "bump2d", "fv2d", (16, 16))
    jac = case.pde.make_jacobian(case.state)
    J = jac(2.0, np.array(res.final).ravel())
    J = J.toarray() if sparse.issparse(J) else np.asarray(J)
    assert _spectrum_angle(J) > bdf_alpha(4)
    assert res.settings["max_order"] == A_STABLE_ORDER


def test_default_orders_and_warnings():
    fv2d, fd = (JacobianStructure(**choice_asks(name)["structure"]) for name in ("fv2d", "fd"))
    assert fv2d.advected and not fd.advected
    for request in ("auto", "native", "pde", "petsc"):
        choice = choose(method="CVODE", request=request, **choice_asks("fv2d", request=request, cells=32 * 32))
        assert (choice.max_order, choice.warning) == (A_STABLE_ORDER, ""), request
    assert choose(method="CVODE", **choice_asks("fd")).max_order == BDF_MAX_ORDER
    order, warning = time_order("CVODE", fv2d, 5)
    assert order == 5 and "max_order 2" in warning
    for method in ("BDF", "LSODA"):  # scipy's BDF orders cannot be capped
        assert "Radau" in time_order(method, fv2d)[1]
    assert time_order("Radau", fv2d) == (A_STABLE_ORDER, "")
    assert time_order("CVODE", fd, 3) == (3, "")
    with pytest.raises(ParameterError, match=r"`max_order` must be an integer in \[1, 5\]; got 6"):
        time_order("CVODE", fv2d, 6)


# --- the model of the artefact: short waves advected in uniform shear under a dominant slow mode ---------

L, H, DAMPING = 30.0, 30.0, 0.03


def sheared_waves(nx: int, nz: int = 12, seed: int = 0):
    """y_t = -U(z) D_x y - d y on rows z_j of a uniform shear U = 1.5 z / H, D_x central on the
    periodic x (cell hx = L / nx): each discrete Fourier mode of each row is exact as
    a(t) = a(0) exp(-d t) (its eigenvalue -d - i U sin(xi hx)/hx). The top row carries a wave
    k = 1 of amplitude 1 (it sets CVODE's steps, as the bump does in bump2d), the others short
    waves at 1e-10, below the tolerance, as round-off seeds them in a run."""
    hx = L / nx
    U = 1.5 * (np.arange(nz) + 0.5) / nz
    shift = sparse.diags([np.ones(nx - 1), np.ones(1)], [1, -(nx - 1)], shape=(nx, nx))
    Dx = (shift - shift.T) / (2 * hx)
    J = (sparse.kron(sparse.diags(-U), Dx) - DAMPING * sparse.identity(nx * nz)).tocsc()
    x = np.arange(nx) * hx
    y0 = 1e-10 * np.random.default_rng(seed).standard_normal((nz, nx))
    y0[-1] = np.cos(2 * np.pi * x / L)
    problem = Problem(y0=y0.ravel(), fun=lambda t, y: J @ y,
                      jacobian=JacobianSpec("sparse", jac=lambda t, y: J, sparsity=J), check=lambda y: None)
    return problem, nz


def short_wave_growth(engine_cls, nx, rtol, max_order, t_end=40.0) -> float:
    """The largest ratio over rows (but the top) and x-wave numbers of the amplitude at t_end to the
    exact one, a(0) exp(-d t_end)."""
    problem, nz = sheared_waves(nx)
    engine = engine_cls("CVODE" if engine_cls.name == "sundae" else engine_cls.methods[0], problem, 0.0,
                        rtol=rtol, atol=rtol * 1e-3, linear_solver="SuperLU_MT", max_order=max_order)
    assert engine.advance(t_end) is None
    y = np.asarray(engine.value_at(t_end)).reshape(nz, nx)
    a0 = np.abs(np.fft.rfft(problem.y0.reshape(nz, nx)[:-1], axis=1))
    a1 = np.abs(np.fft.rfft(y[:-1], axis=1))
    return float(np.max(a1 / (a0 * np.exp(-DAMPING * t_end))))


def _default_order() -> int:
    return choose(method="CVODE", request="pde", **choice_asks("fv2d", request="pde")).max_order


@pytest.mark.parametrize("nx, rtol", [(64, 1e-5), (256, 1e-5), (256, 1e-8)])
def test_advected_waves_do_not_grow_on_the_default(nx, rtol):
    """CVODE with the 2-D cell's default order: no mode ends above its exact amplitude (to 1 %:
    the waves are below the tolerance, so this is the integrator's amplification, not its error)."""
    from icidr_pde.engines.sundae import CvodeEngine

    assert short_wave_growth(CvodeEngine, nx, rtol, _default_order()) < 1.01


def test_bdf5_grows_advected_waves():
    """The same model with orders up to 5 amplifies them (by orders of magnitude): the test above can fail."""
    from icidr_pde.engines.sundae import CvodeEngine

    assert short_wave_growth(CvodeEngine, 256, 1e-5, BDF_MAX_ORDER) > 100


# --- the 2-D cell itself: iCIDR bump2d's short x-waves decay on the default, as the continuum's --------

#: the continuum damps every x-wave of iCIDR at about -0.03 (issue 37): a margin of 0.05
RATE_BOUND = 0.02


def short_wave_rates(n, t0=5.0, t1=10.0, **settings) -> dict:
    """{(field, region): the largest growth rate over t0..t1 of the short x-waves above round-off}."""
    from icidr_pde import run
    from icidr_pde.studies.short_waves import SHORT, growth_rates, wall_rows

    res = run("icidr", "bump2d", (n, n), t1, [f"{t0:g}", f"{t1:g}"], series_times=[], **settings)
    assert not res.blew_up, res.reason
    rates = {}
    for name in ("phi", "w"):
        snapshots = np.asarray(getattr(res, name))
        for region, rows in (("cell", slice(None)), ("wall", wall_rows(n))):
            found = growth_rates(snapshots, [t0, t1], rows, waves=range(SHORT, n // 2 + 1), floor=1e-9)
            rates[name, region] = max(found.values(), default=-np.inf)
    return rates


def test_bump2d_short_waves_decay_on_the_default():
    """At 256^2, every short x-wave of phi and w, over the whole cell and next to the moving wall,
    grows at no more than +0.02 between t = 5 and 10 on the default settings (the py-pde path's
    CVODE + x-Fourier), where orders up to 5 grew them at +0.48 to +0.67 (k = 32-64)."""
    rates = short_wave_rates(256)
    assert max(rates.values()) <= RATE_BOUND, rates


def test_bump2d_short_waves_grow_with_bdf5():
    """The same at 128^2 with orders up to 5: they grow (the test above can fail)."""
    rates = short_wave_rates(128, max_order=5)
    assert max(rates.values()) > 0.1, rates


#: the semi-discrete system's own short-wave rates, resolved by a tight tolerance: w's k = 27-33 at
#: 128^2 grow at +0.04 at rtol 1e-5 and 1e-7 alike, 256^2's at +0.026 at rtol 1e-8 (the scheme's,
#: not the integrator's, which damps more at larger steps: docs/sim2d.md, 'Time integration')
SEMI_DISCRETE_BOUND = 0.05


@pytest.mark.slow
def test_bump2d_short_waves_at_tight_tolerance_and_long_times():
    """rtol 1e-8 at 256^2 to t = 10, where orders up to 5 grew waves at +2.5: no short wave beyond the
    semi-discrete system's own rates; and 512^2 from t = 10 to 20 on the default, within RATE_BOUND."""
    assert max(short_wave_rates(256, rtol=1e-8, atol=1e-11).values()) <= SEMI_DISCRETE_BOUND
    assert max(short_wave_rates(512, t0=10.0, t1=20.0).values()) <= RATE_BOUND


def test_native_engine_takes_the_order():
    """The native 2-D engine runs CVODE with the order the choice names (its C driver's
    CVodeSetMaxOrd): orders up to 2 take more steps than up to 5 on the same run."""
    from icidr_pde import run

    runs = {order: run("icidr", "bump2d", (24, 24), 10.0, ["10"], series_times=[], engine="native",
                       max_order=order) for order in (None, 5)}
    assert runs[None].settings["engine"] == runs[5].settings["engine"] == "native"
    assert runs[None].settings["max_order"] == A_STABLE_ORDER
    assert runs[None].n_steps > 1.5 * runs[5].n_steps
    assert runs[None].to_dict()["max_w"]["10"] == pytest.approx(runs[5].to_dict()["max_w"]["10"], rel=1e-3)


def test_pypde_solve_warns_as_run_does():
    """py-pde's solve() on the 2-D cell with scipy's BDF (orders up to 5, no cap) warns as run() does."""
    from icidr_pde.cells.plane2d.pde import ShearCell2DPDE

    pde = ShearCell2DPDE("icidr")
    state = pde.make_state(pde.make_grid((8, 8), 30.0), 0.78, lambda x, z: z / 30, 0.0)
    with pytest.warns(RuntimeWarning, match="'Radau' \\(L-stable\\)"):
        pde.solve(state, t_range=0.01, solver="stiff", method="BDF", tracker=None)
