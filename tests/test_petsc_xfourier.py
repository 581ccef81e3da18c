"""The x-Fourier preconditioner inside PETSc's KSP (engines/linear/xfourier_shell.py), the PETSc
engine's default on the 2-D cell.

Against independent truth: on a state that does not depend on x the shell preconditioner is the
exact inverse of the matrix it is given (shift I - J, J the Jacobian assembled from the DMDA's
blocks), on 1 rank and on 2, at the shift it was set up for and after the shift changed (the
factors rebuilt without averaging again); on the x-dependent bump2d state it is not (the check can
fail). The engine takes it by default on the 2-D cell and a run on 2 ranks agrees with 1 rank to
1e-8 relative (max|w|, the l2 velocity, t* of mu(I)); against the serial default and on mass see
tests/test_petsc.py (to t = 10, and 48^2 to t = 100).

Run on its own as tests/test_petsc.py is (PETSc cannot share a process with the DEM tests' MPI).
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.test_petsc import HAVE_PETSC, MPIEXEC, _mpi_env, needs_mpiexec, needs_petsc

ROOT = Path(__file__).resolve().parents[1]
#: the shifts 1 / gamma of CVODE's gammas on the 2-D cell (0.01-0.2) and beyond, where the band LU pivots
SHIFTS = (100.0, 5.0, 0.5)


@pytest.fixture(autouse=True)
def _no_lammps_mpi_here():
    """As tests/test_petsc.py: an in-process PETSc test in a worker that ran LAMMPS is skipped."""
    if HAVE_PETSC:
        from icidr_pde.engines.petsc import other_mpi

        if other_mpi() and "petsc4py.PETSc" not in sys.modules:
            pytest.skip("this test process has run LAMMPS (the DEM tests): run tests/test_petsc_xfourier.py "
                        "in a process of its own")


def _state(pde, grid, x_dependent):
    from icidr_pde.cells.plane2d.scenes import Bump2DScene

    if x_dependent:
        return pde.make_state(grid, *Bump2DScene(ell=4.0).initial_condition(pde.nodes(grid)))
    z = pde.nodes(grid)[..., 1]
    return pde.make_state(grid, 0.78 + 0.01 * np.sin(z / 5), z / 30 + 0.02 * np.sin(z / 3),
                          0.01 * np.sin(np.pi * z / 30))


def shell_errors(rheology, shape, x_dependent, newton=False):
    """On this rank: for each shift a of SHIFTS (one set-up after another, as TS shifts the same
    values), max |P^-1 (a I - J) v - v| / max |v| over the ranks, v random, J the Jacobian
    assembled from the DMDA's blocks, P the shell preconditioner of a I - J. `newton`: the matrix
    a I - J is the engine's Newton matrix (J assembled, TS's scale -1 and shift a given to it as
    numbers), its product checked against the assembled a I - J's."""
    from icidr_pde.cells.plane2d.pde import ShearCell2DPDE
    from icidr_pde.engines.linear.xfourier import PetscXFourier
    from icidr_pde.engines.petsc import BlockGrid, NewtonMatrix, _petsc

    PETSc = _petsc()
    comm = PETSc.COMM_WORLD
    pde = ShearCell2DPDE(rheology)
    grid = pde.make_grid(shape, 30.0, L=40.0)
    state = _state(pde, grid, x_dependent)
    solver = PetscXFourier()
    blocks = BlockGrid(PETSc, pde.patches(state), comm, solver.proc_sizes(comm.size))
    x = blocks.da.createGlobalVec()
    blocks.scatter_in(state.data.ravel(), x)
    rows, cols, values = blocks.jacobian_rows(x)
    n = x.getSize()
    keys, where = np.unique(rows.astype(np.int64) * n + cols, return_inverse=True)
    summed = np.zeros(keys.size)
    np.add.at(summed, where, values)
    start, end = x.getOwnershipRange()
    M = PETSc.Mat().create(comm=comm)
    M.setSizes([(end - start, n), (end - start, n)])
    M.setType(PETSc.Mat.Type.AIJ)
    M.setUp()
    M.setPreallocationCOO((keys // n).astype(PETSc.IntType), (keys % n).astype(PETSc.IntType))
    M.setValuesCOO(-summed)  # -J, shifted below
    pc = PETSc.PC().create(comm=comm)
    pc.setType("python")
    pc.setPythonContext(solver.shell(PETSc, blocks))
    if newton:
        J = M.duplicate(copy=True)
        J.scale(-1.0)
        context = NewtonMatrix(J)
        N = PETSc.Mat().createPython(((end - start, n), (end - start, n)), context, comm=comm)
        N.setUp()
        N.assemble()
    pc.setOperators(*(2 * (N if newton else M,)))
    v = x.duplicate()
    blocks.scatter_in(np.random.default_rng(3).standard_normal(n), v)
    b, z = v.duplicate(), v.duplicate()
    errors, shifted = [], 0.0
    for a in SHIFTS:
        M.shift(a - shifted)
        shifted = a
        if newton:  # as TS: J again, then its scale and shift
            context.restore()
            N.scale(-1.0)
            N.shift(a)
            N.mult(v, z)
        pc.setUp()
        M.mult(v, b)
        if newton:
            z.axpy(-1.0, b)
            assert z.norm(PETSc.NormType.INFINITY) <= 1e-13 * b.norm(PETSc.NormType.INFINITY)
        pc.apply(b, z)
        z.axpy(-1.0, v)
        errors.append(z.norm(PETSc.NormType.INFINITY) / v.norm(PETSc.NormType.INFINITY))
    shell = pc.getPythonContext()
    return errors, shell.n_averages, shell.n_factors


@needs_petsc
@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_exact_inverse_on_a_state_independent_of_x(rheology):
    """nx = 12, nz = 10: at every shift, the shell preconditioner inverts a I - J to round-off; the
    values are averaged once and factored at each shift."""
    errors, averages, factors = shell_errors(rheology, (12, 10), x_dependent=False)
    assert max(errors) < 1e-12, errors
    assert (averages, factors) == (1, len(SHIFTS))


@needs_petsc
@pytest.mark.parametrize("rheology", ["icidr", "mui"])
def test_exact_inverse_of_the_engines_newton_matrix(rheology):
    """The engine's Newton matrix (J assembled, TS's scale and shift as numbers) multiplies as the
    assembled a I - J does, and the shell preconditioner set up from it inverts it to round-off:
    J averaged once, factored at each shift (state independent of x, nx = 12, nz = 10)."""
    errors, averages, factors = shell_errors(rheology, (12, 10), x_dependent=False, newton=True)
    assert max(errors) < 1e-12, errors
    assert (averages, factors) == (1, len(SHIFTS))


@needs_petsc
def test_not_the_inverse_where_the_state_depends_on_x():
    """The bump2d state depends on x: the preconditioner inverts the x-average, not J (the check
    above can fail)."""
    errors, _, _ = shell_errors("icidr", (12, 10), x_dependent=True)
    assert min(errors) > 1e-6, errors


SHELL_SCRIPT = """
import json, sys
sys.path.insert(0, sys.argv[2])
from icidr_pde.engines.petsc import rank
from test_petsc_xfourier import shell_errors
out = [shell_errors(r, shape, False) for r in ("icidr", "mui") for shape in ((12, 10), (9, 7))]
with open(sys.argv[1] + str(rank()), "w") as f:
    json.dump(out, f)
"""


@needs_petsc
@needs_mpiexec
def test_exact_inverse_on_two_ranks(tmp_path):
    """On 2 ranks (each its own z rows and its own wave numbers: even and odd Nx, 4 or 7 and 3 or 5
    wave numbers per rank), the same round-off inverse as on one."""
    script = tmp_path / "shell.py"
    script.write_text(SHELL_SCRIPT)
    out = tmp_path / "shell"
    subprocess.run([MPIEXEC, "-n", "2", sys.executable, str(script), str(out), str(ROOT / "tests")],
                   env=_mpi_env(), check=True, timeout=600, capture_output=True)
    for per_rank in zip(*[json.loads((tmp_path / f"shell{r}").read_text()) for r in (0, 1)]):
        for errors, averages, factors in per_rank:
            assert max(errors) < 1e-12 and (averages, factors) == (1, len(SHIFTS)), per_rank


RANKS_SCRIPT = """
import json, sys
from icidr_pde import run
from icidr_pde.engines.petsc import rank
icidr = run("icidr", "bump2d", t_end=2.0, N=(16, 16), engine="petsc", progress=False, times=["1", "2"])
mui = run("mui", "bump2d", t_end=6.0, N=(MUI_N, MUI_N), engine="petsc", progress=False, times=["0.1"])
if rank() == 0:
    d = icidr.to_dict()
    with open(sys.argv[1], "w") as f:
        json.dump({"solver": icidr.settings["linear_solver"], "ranks": icidr.settings["ranks"],
                   "series": list(map(float, icidr.max_w_series)), "l2": [d["l2_velocity"][t] for t in ("1", "2")],
                   "mui_blew_up": mui.blew_up, "t_star": mui.t_star}, f)
"""
#: a mu(I) bump2d grid that fails before t = 6 (phi leaves its range at t* = 4.27)
MUI_N = 12


@needs_petsc
@needs_mpiexec
def test_two_ranks_agree_with_one():
    """iCIDR bump2d 16^2 to t = 2 (the max|w| series, the l2 velocity at t = 1 and 2) and the
    failure time of mu(I) bump2d on 1 and 2 ranks, the x-Fourier preconditioner on both: within
    1e-8 relative (each rank its own wave numbers; sums in another order)."""
    import tempfile

    results = []
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "ranks.py"
        script.write_text(RANKS_SCRIPT.replace("MUI_N", str(MUI_N)))
        for ranks in (1, 2):
            out = Path(tmp) / f"r{ranks}.json"
            subprocess.run([MPIEXEC, "-n", str(ranks), sys.executable, str(script), str(out)], env=_mpi_env(),
                           check=True, timeout=1200, capture_output=True)
            results.append(json.loads(out.read_text()))
    one, two = results
    assert one["solver"].endswith("PC x-Fourier") and two["solver"].endswith("PC x-Fourier (2 MPI ranks)")
    assert (one["ranks"], two["ranks"]) == (1, 2)
    assert len(one["series"]) > 2 and np.allclose(two["series"], one["series"], rtol=1e-8, atol=0)
    assert np.allclose(two["l2"], one["l2"], rtol=1e-8, atol=0)
    assert one["mui_blew_up"] and two["mui_blew_up"]
    assert two["t_star"] == pytest.approx(one["t_star"], rel=1e-8)
