"""What the MPI ranks agree on (icidr_pde/mpi_ranks.py) under ``mpiexec -n 2``, where the PETSc
engine runs.

Against independent truth: under a launcher whose variables mpi_ranks does not read (here Open
MPI's, with the names it reads replaced by one that is not set), once PETSc is started the ranks
still agree through its COMM_WORLD: how many they are, who is rank 0 (who writes), rank 0's
object on every rank, the largest number and status; a run of the PETSc engine gives rank 1 the
same result as rank 0. An uncaught exception on one rank ends every rank with a non-zero status,
well within the time a rank waiting for it in a collective would otherwise wait forever.

Run on its own as tests/test_petsc.py is (PETSc cannot share a process with the DEM tests' MPI).
"""

import json
import subprocess
import sys

import pytest

from tests.test_petsc import MPIEXEC, _mpi_env, needs_mpiexec, needs_petsc

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
