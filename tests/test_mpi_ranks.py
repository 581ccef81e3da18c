"""What the MPI ranks agree on (icidr_pde/mpi_ranks.py): how many processes the launcher started,
read from the variables each launcher sets, and under ``mpiexec -n 2``, where the PETSc engine
runs, what the ranks agree on.

The launchers' variables are those a real launcher sets: Open MPI's mpiexec (4.1.4) and MPICH's
Hydra (5.0.2) as measured here (``mpiexec -n 2 env``), Slurm's srun as its source and manual say
(srun(1), sbatch(1), src/common/env.c, src/plugins/mpi/pmi2/mpi_pmi2.c): srun is not installed on
this machine, so its environments are written from Slurm's documentation, not measured. Each
environment's count is the one its launcher means, also where another launcher's variables are
left in it.

Against independent truth: under a launcher whose variables mpi_ranks does not read (here Open
MPI's, with the names it reads replaced by one that is not set), once PETSc is started the ranks
still agree through its COMM_WORLD: how many they are, who is rank 0 (who writes), rank 0's
object on every rank, the largest number and status, and the command line's exit status (rank 0
alone fails to write its output: 4 on both ranks); a run of the PETSc engine gives rank 1 the
same result as rank 0. An uncaught exception on one rank ends every rank with a non-zero status,
well within the time a rank waiting for it in a collective would otherwise wait forever.

Run on its own as tests/test_petsc.py is (PETSc cannot share a process with the DEM tests' MPI).
"""

import json
import os
import subprocess
import sys

import pytest

from icidr_pde import mpi_ranks
from tests.test_petsc import MPIEXEC, _mpi_env, needs_mpiexec, needs_petsc

#: what each launcher sets (a subset: the variables of ranks, sizes and jobs), for a task of rank 1 of 4
#: unless said otherwise
OPEN_MPI = {"OMPI_COMM_WORLD_SIZE": "4", "OMPI_COMM_WORLD_RANK": "1", "OMPI_COMM_WORLD_LOCAL_SIZE": "4",
            "OMPI_COMM_WORLD_LOCAL_RANK": "1", "OMPI_UNIVERSE_SIZE": "4", "PMIX_RANK": "1", "PMIX_NAMESPACE": "175767553"}
HYDRA = {"PMI_SIZE": "4", "PMI_RANK": "1", "PMI_FD": "9", "PMI_HOSTNAME": "vm"}
#: srun -n 4: every task's step variables (env_array_for_step) and its rank
SRUN = {"SLURM_JOB_ID": "77", "SLURM_STEP_ID": "0", "SLURM_NTASKS": "4", "SLURM_NPROCS": "4",
        "SLURM_STEP_NUM_TASKS": "4", "SLURM_STEP_NUM_NODES": "1", "SLURM_PROCID": "1", "SLURM_LOCALID": "1"}
#: what srun's MPI plugin adds: --mpi=pmi2 (mpi_p_slurmstepd_task), --mpi=pmix (PMIx's own)
SRUN_PMI2 = {"PMI_FD": "5", "PMI_JOBID": "77.0", "PMI_RANK": "1", "PMI_SIZE": "4"}
SRUN_PMIX = {"PMIX_RANK": "1", "PMIX_NAMESPACE": "slurm.pmix.77.0"}
#: a batch script of a job of 4 tasks (sbatch(1)): one process, the job's tasks in SLURM_NTASKS
BATCH = {"SLURM_JOB_ID": "77", "SLURM_NTASKS": "4", "SLURM_NPROCS": "4", "SLURM_PROCID": "0", "SLURM_NODEID": "0"}
#: the shell of `srun -n 4 --pty bash` (its task 0): the step's variables stay in what it starts
INTERACTIVE_STEP = dict(SRUN, SLURM_PROCID="0", SLURM_LOCALID="0")
#: a step of one task per node that an mpiexec starts its daemons with (the ranks on the second node)
DAEMON_STEP = dict(SRUN, SLURM_STEP_NUM_TASKS="2", SLURM_NTASKS="2", SLURM_NPROCS="2", SLURM_PROCID="1",
                   SLURM_LOCALID="0")


@pytest.mark.parametrize("environment, count, rank", [
    ({}, 1, 0),
    (OPEN_MPI, 4, 1),
    (HYDRA, 4, 1),
    (SRUN, 4, 1),  # --mpi=none: no MPI variable, the step's tasks
    ({**SRUN, **SRUN_PMI2}, 4, 1),
    ({**SRUN, **SRUN_PMIX}, 4, 1),
    (BATCH, 1, 0),
    # mpiexec -n 2 in the shell of a step of 4 tasks: 2 ranks (the largest variable would say 4)
    ({**INTERACTIVE_STEP, **OPEN_MPI, "OMPI_COMM_WORLD_SIZE": "2"}, 2, 1),
    ({**INTERACTIVE_STEP, **HYDRA, "PMI_SIZE": "2"}, 2, 1),
    # mpiexec -n 8 across the nodes of an allocation, a rank (5) on a node whose daemon srun started
    ({**DAEMON_STEP, **OPEN_MPI, "OMPI_COMM_WORLD_SIZE": "8", "OMPI_COMM_WORLD_RANK": "5", "PMIX_RANK": "5"}, 8, 5),
    ({**DAEMON_STEP, **HYDRA, "PMI_SIZE": "8", "PMI_RANK": "5"}, 8, 5),
    # mpiexec -n 2 in a batch script: the job's 4 tasks are not the command's
    ({**BATCH, **OPEN_MPI, "OMPI_COMM_WORLD_SIZE": "2"}, 2, 1),
], ids=["no launcher", "Open MPI", "Hydra", "srun --mpi=none", "srun --mpi=pmi2", "srun --mpi=pmix",
        "batch script", "Open MPI in an srun step", "Hydra in an srun step", "Open MPI across nodes",
        "Hydra across nodes", "Open MPI in a batch script"])
def test_the_processes_a_launcher_started_and_this_ones_rank(monkeypatch, environment, count, rank):
    """launched() and launcher_rank() on the environment each launcher gives a process, with the
    variables of an outer launcher (Slurm's) left in it where it runs inside one."""
    for name in list(os.environ):
        if name.startswith(("OMPI_", "PMI", "SLURM_")):
            monkeypatch.delenv(name)
    for name, value in environment.items():
        monkeypatch.setenv(name, value)
    assert (mpi_ranks.launched(), mpi_ranks.launcher_rank()) == (count, rank)

UNKNOWN_LAUNCHER_SCRIPT = """
import json, sys
from icidr_pde import mpi_ranks

# a launcher mpi_ranks does not know: none of the variables it reads is set
mpi_ranks.RANK_VARIABLES = mpi_ranks.SIZE_VARIABLES = ("ICIDR_PDE_TEST_UNSET_LAUNCHER_VARIABLE",)
before = {"launched": mpi_ranks.launched(), "ranks": mpi_ranks.ranks()}
from icidr_pde import run

r = run("icidr", "bump2d", t_end=0.3, N=(16, 16), engine="petsc", progress=False, times=["0.1", "0.3"])
from petsc4py import PETSc

rank = PETSc.COMM_WORLD.rank
record = {"before": before, "ranks": mpi_ranks.ranks(), "rank": mpi_ranks.rank(), "writes": mpi_ranks.writes_here(),
          "from_root": mpi_ranks.broadcast(f"from rank {rank}"), "largest": mpi_ranks.reduce_max(10.0 + rank),
          "status": mpi_ranks.agree(3 if rank == 1 else 0), "everywhere": mpi_ranks.everywhere([True, rank == 0]).tolist(),
          "run_ranks": r.settings["ranks"], "reason": r.reason, "max_w": list(map(float, r.max_w)),
          "mass_drift": r.mass_drift}
with open(f"{sys.argv[1]}.{rank}", "w") as f:
    json.dump(record, f)
"""


@needs_petsc
@needs_mpiexec
def test_ranks_agree_through_petsc_under_a_launcher_not_recognised(tmp_path):
    script = tmp_path / "unknown_launcher.py"
    script.write_text(UNKNOWN_LAUNCHER_SCRIPT)
    out = tmp_path / "record"
    proc = subprocess.run([MPIEXEC, "-n", "2", sys.executable, str(script), str(out)], env=_mpi_env(),
                          timeout=600, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    records = [json.loads((tmp_path / f"record.{r}").read_text()) for r in (0, 1)]
    for rank, record in enumerate(records):
        assert record["before"] == {"launched": 1, "ranks": 1}  # the launcher's variables say one process
        assert (record["ranks"], record["rank"], record["writes"]) == (2, rank, rank == 0)
        assert record["from_root"] == "from rank 0" and record["largest"] == 11.0 and record["status"] == 3
        assert record["everywhere"] == [True, False]
        assert record["run_ranks"] == 2 and record["reason"] == "reached t_end"
    assert records[1]["max_w"] == records[0]["max_w"] and records[1]["mass_drift"] == records[0]["mass_drift"]
    assert len(records[0]["max_w"]) > 2


FAILING_RANK_SCRIPT = """
import sys
from icidr_pde import mpi_ranks

assert mpi_ranks.ranks() == 2  # MPI started: the ranks agree through PETSc
if mpi_ranks.rank() == 1:
    raise RuntimeError("rank 1 fails alone")
mpi_ranks.agree(0)  # rank 0 waits here for rank 1
with open(sys.argv[1], "w") as f:
    f.write("rank 0 went on")
"""

CLI_FAILING_RANK_SCRIPT = """
import sys
from icidr_pde.cli import main
from icidr_pde.engines.petsc import BlockGrid

rates = BlockGrid.rates


def failing(self, x, f):  # rank 1's right-hand side fails once the run is under way
    failing.calls += 1
    if self.da.getComm().rank == 1 and failing.calls > 20:
        raise RuntimeError("rank 1's right-hand side fails alone")
    return rates(self, x, f)


failing.calls = 0
BlockGrid.rates = failing
sys.exit(main(sys.argv[1:]))
"""


@needs_petsc
@needs_mpiexec
@pytest.mark.parametrize("script, raised", [(FAILING_RANK_SCRIPT, "RuntimeError: rank 1 fails alone"),
                                            (CLI_FAILING_RANK_SCRIPT, "RuntimeError: rank 1's right-hand side")])
def test_an_uncaught_exception_on_one_rank_ends_every_rank(tmp_path, script, raised):
    """Rank 1 raises, rank 0 waits for it in a collective: mpiexec ends with a non-zero status
    (without the abort it would wait past the timeout: rank 1 in MPI_Finalize, rank 0 in the
    collective), rank 1's traceback shown once, and rank 0 went no further."""
    path = tmp_path / "fails.py"
    path.write_text(script)
    argv = ([str(tmp_path / "went_on")] if script is FAILING_RANK_SCRIPT else
            ["run", "--engine", "petsc", "--scene", "bump2d", "--N", "16", "--t-end", "5", "--no-progress",
             "--json", str(tmp_path / "went_on")])
    proc = subprocess.run([MPIEXEC, "-n", "2", sys.executable, str(path), *argv], env=_mpi_env(), timeout=300,
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode != 0, proc.stderr[-3000:]
    assert proc.stderr.count(raised) == 1 and proc.stderr.count("Traceback") == 1, proc.stderr[-3000:]
    assert not (tmp_path / "went_on").exists()


@needs_petsc
@pytest.mark.parametrize("rank", [0, 1])
def test_a_task_of_srun_whose_mpi_petsc_does_not_join_is_refused_in_one_line(tmp_path, rank):
    """A task of ``srun -n 4`` without an MPI plugin that PETSc's MPI uses (here Slurm's variables
    as srun sets them, in one process: srun is not installed here) is a 1-rank PETSc run, where the
    launcher started 4: refused as bad input (each would run the whole grid alone, every one of the
    4 writing), said by rank 0 alone, status 2 on each, nothing written."""
    env = {name: value for name, value in _mpi_env().items() if not name.startswith(("OMPI_COMM", "PMI", "SLURM_"))}
    env.update(SRUN, SLURM_PROCID=str(rank), SLURM_LOCALID=str(rank))
    run = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "run", "--engine", "petsc", "--scene", "bump2d",
                          "--N", "8", "--t-end", "0.01", "--no-progress", "--json", str(tmp_path / "r.json")],
                         env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 2, run.stderr[-3000:]
    if rank == 0:
        assert run.stderr.count("\n") == 1 and "one of 4 started by" in run.stderr and "srun" in run.stderr
    else:
        assert run.stderr == ""
    assert run.stdout == "" and not (tmp_path / "r.json").exists()


CLI_UNKNOWN_LAUNCHER_SCRIPT = """
import errno, sys
from icidr_pde import mpi_ranks, outputs
from icidr_pde.cli import main

# a launcher mpi_ranks does not know: none of the variables it reads is set
mpi_ranks.RANK_VARIABLES = mpi_ranks.SIZE_VARIABLES = ("ICIDR_PDE_TEST_UNSET_LAUNCHER_VARIABLE",)


def full(tmp, path, **kwargs):  # the disk rank 0 writes to is full (rank 0 alone installs files)
    raise OSError(errno.ENOSPC, "No space left on device")


outputs.install = full
status = main(sys.argv[2:])
from petsc4py import PETSc

with open(f"{sys.argv[1]}.{PETSc.COMM_WORLD.rank}", "w") as f:
    f.write(str(status))
"""


@needs_petsc
@needs_mpiexec
def test_the_ranks_exit_statuses_agree_under_a_launcher_not_recognised(tmp_path):
    """The PETSc engine's run on 2 ranks of a launcher whose variables mpi_ranks does not read,
    rank 0 alone failing to write the JSON: 4 on rank 0, and 4 on rank 1 too, which wrote nothing
    (its own status would be 0): the ranks agree once PETSc's COMM_WORLD says there are 2."""
    script = tmp_path / "cli_unknown_launcher.py"
    script.write_text(CLI_UNKNOWN_LAUNCHER_SCRIPT)
    status = tmp_path / "status"
    proc = subprocess.run([MPIEXEC, "-n", "2", sys.executable, str(script), str(status), "run", "--engine", "petsc",
                           "--scene", "bump2d", "--N", "8", "--t-end", "0.01", "--no-progress", "--json",
                           str(tmp_path / "r.json")], env=_mpi_env(), timeout=600, capture_output=True, text=True)
    assert [(tmp_path / f"status.{r}").read_text() for r in (0, 1)] == ["4", "4"], proc.stderr[-3000:]
    assert "could not write --json" in proc.stderr and "No space left on device" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "r.json").exists()
