"""The 2-D cell (fv2d) on the native engine (icidr_pde.cells.plane2d.native).

Independent truths: the numba kernel of the same template (the C is printed from it), the
py-pde path's CVODE + GMRES run (solver B: scikit-sundae, Python rates), the 1-D native fd run
of the same x-independent data (the 2-D scheme reduces to the 1-D one), mass conservation,
py-pde's boundary setters for the walls, and sys.modules of a fresh process.
"""

import json
import os
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from icidr_pde import run
from icidr_pde.cells import choice_asks, get_cell
from icidr_pde.engines.choose import FOURIER_SOLVER, choose
from icidr_pde.cells.plane2d.scenes import Bump2DScene, Scene2D
from icidr_pde.native_case import Plane2DCase

HEAVY = ("pde", "numba", "scipy", "sympy", "sksundae", "matplotlib")
#: CVODE's tolerances of the comparisons (the tests' usual 2-D setting)
TOL = dict(method="CVODE", rtol=1e-7, atol=1e-10)


def _perturbed(case, seed=1):
    rng = np.random.default_rng(seed)
    n = case.y0.size // 3
    return case.y0 + 1e-3 * rng.standard_normal(case.y0.size) * np.repeat([0.01, 1.0, 1.0], n)


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["central", "upwind"])
def test_c_rates_are_the_numba_kernels(rheology, advection):
    from icidr_pde.case import build_case

    native = Plane2DCase(rheology, "bump2d", (16, 24), advection=advection)
    pde_case = build_case(rheology, "bump2d", "fv2d", (16, 24), options={"advection": advection})
    assert np.array_equal(native.y0, pde_case.state.data.ravel())  # the same cells and initial data
    numba_rates = pde_case.pde.make_rates(pde_case.state)
    y = _perturbed(native)
    c, ref = native.problem().rates(y), numba_rates(y.reshape(3, 16, 24)).ravel()
    assert np.max(np.abs(c - ref)) <= 1e-13 * np.max(np.abs(ref))


def test_walls_are_py_pdes_boundary_setters():
    from icidr_pde.case import build_case

    pde_case = build_case("icidr", "bump2d", "fv2d", (8, 6))
    assert np.array_equal(Plane2DCase("icidr", "bump2d", (8, 6)).scheme.ghost,
                          pde_case.pde.ghost_coefficients(pde_case.grid))


def _measures(result):
    d = result.to_dict()
    return np.array([[d[q][t] for t in result.time_labels] for q in ("max_w", "l2_velocity")])


def test_native_run_is_the_pde_run_to_the_tolerance_and_conserves_mass():
    times = ["0", "0.5", "1", "2", "5"]
    native = run("icidr", "bump2d", (32, 32), 5.0, times, engine="native", **TOL)
    pde = run("icidr", "bump2d", (32, 32), 5.0, times, engine="pde", **TOL)
    assert native.settings["engine"] == "native" and native.settings["linear_solver"] == "GMRES"
    assert pde.settings["engine"] == "sundae"
    assert not native.blew_up and native.t_final == 5.0
    a, b = _measures(native), _measures(pde)
    assert np.max(np.abs(a - b) / np.abs(b)) < 1e-5, (a, b)
    assert np.max(np.abs(a[0] - a[0, 0])) > 1e-3  # the bump did evolve
    assert abs(native.mass_drift) < 1e-13
    assert set(native.to_dict()) == set(pde.to_dict())


@dataclass(frozen=True)
class _XUniform(Scene2D):
    """bump1d's data on the 2-D cell: x-independent."""

    name = "xuniform"

    def initial_condition(self, xz):
        return Bump2DScene(H=self.H, phi0=self.phi0).x_independent().initial_condition(xz[..., 1])


@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_x_uniform_data_give_the_1d_native_run(rheology):
    nz, t_end = 24, 4.0
    two = run(rheology, _XUniform(), (8, nz), t_end, ["0", "1", str(t_end)], advection="upwind",
              engine="native", **TOL)
    one = run(rheology, Bump2DScene().x_independent(), nz, t_end, ["0", "1", str(t_end)], discretization="fd",
              advection="upwind", engine="native", max_order=two.settings["max_order"], **TOL)  # the same integrator
    assert two.settings["engine"] == one.settings["engine"] == "native"
    assert not two.blew_up and not one.blew_up
    for k in range(3):
        scale = np.max(np.abs(one.final[k])) if k else 1.0
        assert np.max(np.abs(two.final[k] - one.final[k][None, :])) < 1e-5 * scale, k
    assert np.max(np.abs(np.ptp(two.final[2], axis=0))) < 1e-9  # and stay x-independent


def test_native_gmres_runs_at_the_tight_krylov_tolerance():
    """eps_lin = KRYLOV_EPS_LIN (the py-pde path's), not SUNDIALS' 0.05: more products J v (one RHS each)."""
    from icidr_pde.engines.base import KRYLOV_EPS_LIN
    from icidr_pde.cells.plane2d.native import Plane2DProblem

    case, rhs = Plane2DCase("mui", "bump2d", (16, 16)), {}
    for eps_lin in (None, 0.05):
        c = case.scheme
        problem = Plane2DProblem(case.rheology, c.Nx, c.Nz, c.hx, c.hz, eps_lin=eps_lin)
        problem.start(case.y0, rtol=1e-7, atol=1e-10)
        done, status, _ = problem.advance(np.array([0.5]), np.array([-1]), np.empty(1), np.empty((1, case.y0.size)))
        assert (done, status) == (1, 0)
        rhs[eps_lin] = problem.counts()["rhs"]
        assert problem.eps_lin == (KRYLOV_EPS_LIN if eps_lin is None else eps_lin)
    assert rhs[None] > 1.1 * rhs[0.05]


def test_mui_t_star_is_the_pde_paths():
    native = run("mui", "bump2d", (32, 32), 10.0, ["0"], series_times=[], engine="native", **TOL)
    pde = run("mui", "bump2d", (32, 32), 10.0, ["0"], series_times=[], engine="pde", **TOL)
    assert native.blew_up and pde.blew_up
    assert native.t_star == pytest.approx(pde.t_star, rel=1e-3)


def _choose_fv2d(method="CVODE", request="auto", thin_cell=False, cells=None, **kw):
    """choose on the 2-D cell, asked as the run path asks it (:func:`icidr_pde.cells.choice_asks`)."""
    return choose(method=method, request=request, **choice_asks("fv2d", request=request, thin_cell=thin_cell,
                                                                cells=cells), **kw)


def test_choose_takes_native_for_thick_cells_up_to_its_measured_size():
    assert _choose_fv2d().engine == "native" and _choose_fv2d().linear_solver == "GMRES"
    assert _choose_fv2d(jacobian="krylov").engine == "native"
    thin = _choose_fv2d(thin_cell=True)
    assert thin.engine == "sundae" and "thin" in thin.reason
    assert _choose_fv2d(request="pde").engine == "sundae"
    limit = get_cell("plane2d").native_auto_cells
    assert _choose_fv2d(cells=limit).engine == "native"
    large = _choose_fv2d(cells=limit + 1)
    assert large.engine == "sundae" and "py-pde path measured faster" in large.reason
    assert _choose_fv2d(cells=limit + 1, request="native").engine == "native"
    assert _choose_fv2d(cells=limit + 1, request="native", thin_cell=True).engine == "sundae"
    assert _choose_fv2d(jacobian="sparse").engine == "sundae"
    assert _choose_fv2d(method="BDF").engine == "scipy"
    # beyond it, the py-pde path's default: GMRES preconditioned by the x-averaged Jacobian
    assert (large.jacobian, large.linear_solver) == ("fourier", FOURIER_SOLVER)
    assert _choose_fv2d(cells=limit + 1, jacobian="krylov").jacobian == "krylov"


def test_thin_cell_runs_on_the_pde_path():
    r = run("icidr", "bump2d", (8, 8), 0.01, ["0"], series_times=[], L=30.0, H=3.0, **TOL)  # hx/hz = 10
    assert r.settings["engine"] == "native"
    r = run("icidr", "bump2d", (8, 8), 0.01, ["0"], series_times=[], L=30.0, H=2.9, **TOL)  # hx/hz = 10.3
    assert r.settings["engine"] == "sundae"


def test_native_2d_run_imports_no_py_pde_numba_or_scipy(tmp_path):
    argv = ["run", "--scene", "bump2d", "--N", "12", "--t-end", "0.2", "--no-progress", "--method", "CVODE"]
    from icidr_pde import cli

    assert cli.main(argv + ["--json", str(tmp_path / "warm.json")]) == 0  # builds the library if missing
    target = tmp_path / "r.json"
    code = (f"import sys, json, icidr_pde.cli\nstatus = icidr_pde.cli.main({argv + ['--json', str(target)]!r})\n"
            "print(json.dumps([status, sorted({m.split('.')[0] for m in sys.modules})]))")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    status, modules = json.loads(proc.stdout.strip().splitlines()[-1])
    assert status == 0, proc.stderr
    assert not set(HEAVY) & set(modules), set(HEAVY) & set(modules)
    data = json.loads(target.read_text())
    assert data["settings"]["engine"] == "native" and data["Nx"] == 12 and data["t_final"] == 0.2


def test_a_run_too_stiff_for_the_native_gmres_takes_the_pde_path(capsys):
    """Asked for the native engine on a run whose t_end / fastest time scale exceeds what its
    unpreconditioned GMRES follows (Plane2DProblem.max_stiffness), the run says so on stderr and
    is the py-pde path's run: the same numbers as asking for that path."""
    kwargs = dict(rheology="icidr", scene="bump2d", N=(8, 8), t_end=2e9, times=[0, 1e-3, 2e9], progress=False)
    fell_back = run(engine="native", **kwargs)
    said = capsys.readouterr().err
    assert "native engine not available" in said and "too stiff" in said
    direct = run(engine="pde", **kwargs)
    assert fell_back.settings["engine"] == direct.settings["engine"] != "native"
    assert np.array_equal(fell_back.final, direct.final) and not fell_back.blew_up
