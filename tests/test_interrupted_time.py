"""An interrupted run (Ctrl-C, SIGTERM) returns the time its engine reached, its last accepted
step, and the state there; not the last output's (a run with outputs at 0 and t_end only
reported "interrupted at t = 0" and the initial state after hours of steps).

Each engine is interrupted part-way, as Ctrl-C interrupts it: inside a right-hand side (scipy,
scikit-sundae's CVODE: Python runs there), once a call into C has returned (native: C runs
without Python in between), after a step (PETSc: where its ranks agree on a signal). The
independent truth is an uninterrupted run of the same case to exactly the time reached.
"""

import dataclasses
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from icidr_pde.api import run
from icidr_pde.cells.shear1d.scenes import ShearScene

HAVE_PETSC = importlib.util.find_spec("petsc4py") is not None  # the [petsc] extra, not in [test]
needs_petsc = pytest.mark.skipif(not HAVE_PETSC, reason="petsc4py is not installed (the [petsc] extra): "
                                 "the PETSc engine's interrupt is not tested")

T_END = 1.0
RTOL = 1e-7
#: the 1-D shear cell (N = 21; without its chi samples, which are outputs too) and the 2-D bump (16^2)
SHEAR = dict(rheology="icidr", scene=ShearScene(outputs=("max_w", "snapshots")), N=21)
BUMP = dict(rheology="icidr", scene="bump2d", N=(16, 16))


def interrupt_inside_the_rates(monkeypatch, engine_cls, after: float):
    """Ctrl-C inside the first right-hand side evaluated beyond t = `after` (the engine's own
    Problem's rates: mid-step, as a signal lands in Python code there)."""
    original = engine_cls.__init__

    def interrupting(f):
        if f is None:
            return None

        def rates(t, *args):
            if t > after:
                raise KeyboardInterrupt
            return f(t, *args)

        return rates

    def init(self, method, problem, t0, **options):
        problem = dataclasses.replace(problem, fun=interrupting(problem.fun), fun_into=interrupting(problem.fun_into))
        original(self, method, problem, t0, **options)

    monkeypatch.setattr(engine_cls, "__init__", init)


def reached(case, engine, interrupt, series_times=(), **options):
    """(the interrupted Result, the uninterrupted Result to its time reached); the interrupted
    run's outputs at 0 and t_end only and at `series_times` (max|w|)."""
    args = (case["rheology"], case["scene"], case["N"])
    stopped = run(*args, T_END, ["0", f"{T_END:g}"], engine=engine, rtol=RTOL, series_times=series_times, **options)
    interrupt.undo()
    assert stopped.interrupted and not stopped.blew_up, stopped.reason
    assert stopped.reason == f"interrupted at t = {stopped.t_final:.6g}"
    assert 0 < stopped.t_final < T_END
    outputs = np.concatenate([stopped.times, stopped.max_w_t, stopped.chi_t if stopped.chi_t is not None else []])
    assert stopped.t_final > outputs.max()  # past the last output reached: the step reached
    # the same series: CVODE's first step is bounded by the first output time
    full = run(*args, stopped.t_final, ["0", repr(stopped.t_final)], engine=engine, rtol=RTOL,
               series_times=series_times, **options)
    assert full.reason == "reached t_end" and full.t_final == stopped.t_final
    return stopped, full


def assert_same_state(stopped, full):
    """The state reported agrees with the uninterrupted run's at its t_end, within the run's
    tolerance (max|w| to 10 rtol; each field to 10 rtol of its own size)."""
    w_stopped, w_full = np.max(np.abs(stopped.final.w)), np.max(np.abs(full.final.w))
    assert w_full > 0 and abs(w_stopped - w_full) <= 10 * RTOL * w_full, (w_stopped, w_full)
    for name in ("phi", "u", "w"):
        a, b = getattr(stopped.final, name), getattr(full.final, name)
        assert np.max(np.abs(a - b)) <= 10 * RTOL * np.max(np.abs(b)), name
    assert stopped.mass_drift == pytest.approx(full.mass_drift, abs=1e-13)


@pytest.mark.parametrize("case, method", [(SHEAR, "BDF"), (SHEAR, "CVODE"), (BUMP, "CVODE")],
                         ids=["scipy-shear", "sundae-shear", "sundae-bump2d"])
def test_python_engines_report_the_step_reached(monkeypatch, case, method):
    """scipy's BDF and scikit-sundae's CVODE, interrupted inside a right-hand side past T_END / 2:
    the time of the last step accepted before, not t = 0 (the only output before)."""
    from icidr_pde.engines.scipy import ScipyEngine
    from icidr_pde.engines.sundae import CvodeEngine

    interrupt_inside_the_rates(monkeypatch, ScipyEngine if method == "BDF" else CvodeEngine, T_END / 2)
    stopped, full = reached(case, "pde", monkeypatch, method=method)
    assert stopped.settings["engine"] == ("scipy" if method == "BDF" else "sundae")
    assert stopped.t_final <= T_END / 2 and stopped.n_steps > 0
    assert stopped.times.tolist() == [0.0]  # the snapshots stay those of the outputs reached
    assert_same_state(stopped, full)


@pytest.mark.parametrize("case", [SHEAR, BUMP], ids=["shear", "bump2d"])
def test_native_engine_reports_the_step_reached(monkeypatch, case):
    """The native engine, Ctrl-C seen once a call into C has returned past T_END / 2 (the max|w|
    series are its outputs between: without them one call runs to t_end): CVODE's last step,
    past that call's last output (today's report), within one step of it."""
    from icidr_pde import drive
    from icidr_pde.native import NativeProblem, NativeUnavailable
    from icidr_pde.native_case import FdCase

    try:
        FdCase("icidr", "shear", 9).problem()
    except NativeUnavailable:
        pytest.skip("no native engine here")
    original = NativeProblem.advance

    def advance(self, times, *args):
        done = original(self, times, *args)
        if times[-1] > T_END / 2:
            raise KeyboardInterrupt
        return done

    monkeypatch.setattr(NativeProblem, "advance", advance)
    monkeypatch.setattr(drive, "CHUNK", (4, 4, 4))  # 4 outputs a call: the interrupt lands well before t_end
    stopped, full = reached(case, "native", monkeypatch, series_times=None)
    assert stopped.settings["engine"] == "native"
    last_output = stopped.max_w_t[-1]
    assert T_END / 2 < last_output < stopped.t_final
    assert stopped.n_steps > 0
    assert_same_state(stopped, full)


def test_interrupt_before_the_first_step_reports_t_0(monkeypatch):
    """Interrupted inside the first right-hand side of the integration: t = 0, the initial state."""
    from icidr_pde.engines.sundae import CvodeEngine

    interrupt_inside_the_rates(monkeypatch, CvodeEngine, -1.0)
    stopped = run("icidr", SHEAR["scene"], 21, T_END, ["0", f"{T_END:g}"], engine="pde", method="CVODE",
                  series_times=[])
    assert stopped.interrupted and stopped.t_final == 0.0 and stopped.reason == "interrupted at t = 0"
    assert np.array_equal(np.array(stopped.final), np.array([stopped.phi[0], stopped.u[0], stopped.w[0]]))


@needs_petsc
def test_petsc_engine_reports_the_step_reached(monkeypatch):
    """PETSc on one rank, interrupted after a step past T_END / 2 (where its ranks check the step
    and agree on a signal): the last step checked before."""
    from icidr_pde.engines.petsc import PetscEngine, other_mpi

    if other_mpi() and "petsc4py.PETSc" not in sys.modules:
        pytest.skip("this test process has run LAMMPS (the DEM tests): its MPICH and PETSc's MPI cannot share a "
                    "process; run this file in a process of its own")

    original = PetscEngine._invalid_anywhere

    def invalid_anywhere(self):
        if self.ts.getTime() > T_END / 2:
            raise KeyboardInterrupt
        return original(self)

    monkeypatch.setattr(PetscEngine, "_invalid_anywhere", invalid_anywhere)
    stopped, full = reached(BUMP, "petsc", monkeypatch, atol=1e-10)
    assert stopped.settings["engine"] == "petsc"
    assert stopped.t_final <= T_END / 2 and stopped.n_steps > 0
    assert_same_state(stopped, full)


def test_a_step_over_t_end_reports_the_last_output():
    """Interrupted with the engine's last step past t_end (the output at t_end not written): the
    time reported stays before t_end, the last output's (an engine stepping over t_end)."""
    from types import SimpleNamespace

    from icidr_pde.drive import outcome

    class Stepped:
        def last_step(self):
            return 1.25, np.full(3, 3.0)

        def last_good(self):
            return 0.75, np.full(3, 2.0)

    view = SimpleNamespace(fields=lambda y: y, y0=np.zeros(3))
    out = SimpleNamespace(times=np.array([0.5, 0.75, 1.0]))
    ended = outcome(view, Stepped(), out, 2, None, 1.0, 0.0, 0.0, None)
    assert (ended.t_final, ended.reason, ended.final.tolist()) == (0.75, "interrupted at t = 0.75", [2.0] * 3)
    ended = outcome(view, Stepped(), out, 2, None, 2.0, 0.0, 0.0, None)  # the same step before t_end
    assert (ended.t_final, ended.reason, ended.final.tolist()) == (1.25, "interrupted at t = 1.25", [3.0] * 3)


RANKS_SCRIPT = """
import json, os, signal, sys
import numpy as np
from icidr_pde import run
from icidr_pde.engines.petsc import PetscEngine
from icidr_pde.mpi_ranks import launcher_rank

signal.signal(signal.SIGINT, signal.default_int_handler)  # Ctrl-C: KeyboardInterrupt, as at a terminal
original, rank = PetscEngine._invalid_anywhere, launcher_rank()


def invalid_anywhere(self):  # a real SIGINT to rank 0 alone, once past t_end / 2
    if rank == 0 and self.ts.getTime() > T_END / 2 and not self.signalled:
        self.signalled = True
        os.kill(os.getpid(), signal.SIGINT)
    return original(self)


PetscEngine.signalled = False
PetscEngine._invalid_anywhere = invalid_anywhere
case = dict(rheology="icidr", scene="bump2d", N=(16, 16), engine="petsc", rtol=RTOL, atol=1e-10, series_times=[])
stopped = run(t_end=T_END, times=["0", repr(T_END)], **case)
PetscEngine._invalid_anywhere = original
seen = {"reason": stopped.reason, "t_final": stopped.t_final, "ranks": stopped.settings["ranks"]}
if stopped.t_final > 0:  # the uninterrupted run to the time reached (on every rank: a collective run)
    full = run(t_end=stopped.t_final, times=["0", repr(stopped.t_final)], **case)
    seen.update(full_reason=full.reason, full_t_final=full.t_final)
    if rank == 0:
        seen.update(stopped=np.array(stopped.final).tolist(), full=np.array(full.final).tolist())
if rank == 0:
    json.dump(seen, open(sys.argv[1], "w"))
"""


@needs_petsc
def test_petsc_on_two_ranks_reports_the_step_they_reached(tmp_path):
    """PETSc on 2 ranks (mpiexec), a real SIGINT to rank 0 alone past T_END / 2: every rank stops
    after the same step, and rank 0's Result holds that step's time and its state gathered."""
    from icidr_pde.engines.petsc import mpiexec

    launcher = mpiexec()
    if launcher is None:
        pytest.skip("the mpiexec of PETSc's MPI is missing")
    script = tmp_path / "ranks.py"
    script.write_text(f"T_END, RTOL = {T_END!r}, {RTOL!r}\n" + RANKS_SCRIPT)
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]), OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_mpi_yield_when_idle="1")
    done = subprocess.run([launcher, "--oversubscribe", "-n", "2", sys.executable, str(script), str(tmp_path / "r.json")],
                          env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    d = json.loads((tmp_path / "r.json").read_text())
    assert d["ranks"] == 2 and d["reason"] == f"interrupted at t = {d['t_final']:.6g}"
    assert 0 < d["t_final"] <= T_END / 2  # the step before the one the signal came in (0 is the only output)
    assert d["full_reason"] == "reached t_end" and d["full_t_final"] == d["t_final"]
    stopped, full = np.array(d["stopped"]), np.array(d["full"])
    for k in range(3):  # phi, u, w
        assert np.max(np.abs(stopped[k] - full[k])) <= 10 * RTOL * np.max(np.abs(full[k]))
