"""The PETSc engine (engines/petsc.py): against exact solutions of linear systems, a blow-up
time known in closed form, another integrator (CVODE) on the 2-D cell, and 1 against 2 MPI ranks.

Where petsc4py is not importable (CI's fresh environment has no PETSc: the [petsc] extra builds
PETSc from source once) the engine's tests are skipped, and say so; the choice and the error
message without petsc4py are tested everywhere.
"""

import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from icidr_pde.engines.choose import SCHEME_STRUCTURES, choose
from icidr_pde.validation import ParameterError

HAVE_PETSC = importlib.util.find_spec("petsc4py") is not None  # the [petsc] extra, not in [test]
needs_petsc = pytest.mark.skipif(not HAVE_PETSC, reason="petsc4py is not installed (the [petsc] extra, a one-time "
                                 "PETSc build; CI's fresh environment has no PETSc): PETSc engine tests skipped")
ROOT = Path(__file__).resolve().parents[1]


def test_choose_takes_petsc_on_request_or_method():
    fv2d = SCHEME_STRUCTURES["fv2d"]
    for method, request in (("CVODE", "petsc"), ("PETSC-BDF", "auto"), ("PETSC-BDF", "pde")):
        choice = choose(method=method, structure=fv2d, discretization="fv2d", request=request, dim=2)
        assert (choice.engine, choice.jacobian) == ("petsc", "sparse") and "gmres" in choice.linear_solver


def test_choose_refuses_petsc_without_a_sparse_jacobian():
    with pytest.raises(ParameterError, match="sparse Jacobian"):
        choose(method="CVODE", structure=SCHEME_STRUCTURES["cheb"], discretization="cheb", request="petsc")
    with pytest.raises(ParameterError, match="`jacobian` must be 'sparse'"):
        choose(method="CVODE", jacobian="krylov", structure=SCHEME_STRUCTURES["fv2d"], request="petsc")


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
    assert np.allclose(petsc.max_w, cvode.max_w, rtol=1e-4, atol=1e-9)
    assert abs(petsc.mass_drift) < 1e-12


MPI_SCRIPT = """
import sys, numpy as np
from icidr_pde import run
from icidr_pde.engines.petsc import rank
r = run("icidr", "bump2d", t_end=0.3, N=(12, 12), engine="petsc", progress=False)
if rank() == 0:
    np.save(sys.argv[1], np.asarray(r.max_w))
"""


@needs_petsc
@pytest.mark.skipif(shutil.which("mpiexec") is None, reason="mpiexec is not installed: the 2-rank test is skipped")
def test_two_ranks_agree_with_one(tmp_path):
    script = tmp_path / "two.py"
    script.write_text(MPI_SCRIPT)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_mpi_yield_when_idle="1", MPLBACKEND="Agg")
    results = []
    for ranks in (1, 2):
        out = tmp_path / f"w{ranks}.npy"
        subprocess.run(["mpiexec", "-n", str(ranks), sys.executable, str(script), str(out)], env=env, check=True,
                       timeout=600, capture_output=True)
        results.append(np.load(out))
    assert results[0].size > 2
    assert np.allclose(results[1], results[0], rtol=1e-8, atol=0)
