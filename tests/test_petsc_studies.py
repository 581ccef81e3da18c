"""The studies on the PETSc engine under ``mpiexec -n 2`` (icidr_pde/mpi_ranks.py): the t*(N) sweep
of mu(I) on the 2-D bump and the iCIDR 2-D grid-convergence study, and the Slurm job scripts of
docs/slurm that run them on a cluster.

Each command runs as it does serially: every rank computes, rank 0 alone prints and writes. The
ranks here run in folders of their own (the wrapper below changes each rank's working folder
before the command starts), so that an output a rank other than 0 wrote would be found in its
folder; the outputs are compared with the serial command's (another engine: to the engines'
agreement). Skipped where petsc4py or PETSc's mpiexec is missing, and said so.
"""

import importlib.util
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from icidr_pde.engines.petsc import mpiexec

HAVE_PETSC = importlib.util.find_spec("petsc4py") is not None
MPIEXEC = mpiexec()
ROOT = Path(__file__).resolve().parents[1]
pytestmark = [
    pytest.mark.skipif(not HAVE_PETSC, reason="petsc4py is not installed (the [petsc] extra): the PETSc studies "
                       "under mpiexec are skipped"),
    pytest.mark.skipif(MPIEXEC is None, reason="the mpiexec of PETSc's MPI is missing: the PETSc studies under "
                       "mpiexec are skipped"),
]
RANKS = 2

#: `icidr-pde ARGS` on one rank, in the folder FOLDER/rank<R> of its own; its exit status written to
#: FOLDER/status.<R> (mpiexec reports one status for all)
RANK_SCRIPT = """
import os, sys
from icidr_pde.mpi_ranks import launcher_rank
folder = sys.argv[1]
os.chdir(os.path.join(folder, f"rank{launcher_rank()}"))
from icidr_pde.cli import main
try:
    status = main(sys.argv[2:])
except SystemExit as stop:
    status = stop.code
with open(os.path.join(folder, f"status.{launcher_rank()}"), "w") as f:
    f.write(str(status))
sys.exit(status)
"""


def _env(tmp_path, **more):
    """The ranks' environment: this checkout first, Open MPI as root, temporary files in a folder
    of the test's (it must be empty after: no rank leaves a partial or a discarded output)."""
    temporary = tmp_path / "tmp"
    temporary.mkdir(exist_ok=True)
    return dict(os.environ, PYTHONPATH=str(ROOT), OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
                OMPI_MCA_mpi_yield_when_idle="1", MPLBACKEND="Agg", TMPDIR=str(temporary), **more)


def _on_ranks(tmp_path, argv, *, env=None, **popen):
    """mpiexec -q -n 2 of `icidr-pde argv`, each rank in its own folder (tmp_path/rank0, rank1):
    the Popen; rank 0's folder is where the outputs go."""
    script = tmp_path / "ranks.py"
    script.write_text(RANK_SCRIPT)
    for r in range(RANKS):
        (tmp_path / f"rank{r}").mkdir(exist_ok=True)
    command = [MPIEXEC, "-q", "--oversubscribe", "-n", str(RANKS), sys.executable, str(script), str(tmp_path), *argv]
    return subprocess.Popen(command, env=env or _env(tmp_path), cwd=tmp_path, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **popen)


def _finished(tmp_path, proc, timeout=900):
    out, err = proc.communicate(timeout=timeout)
    statuses = [(tmp_path / f"status.{r}").read_text() for r in range(RANKS)]
    return out, err, statuses


def _only_rank0_wrote(tmp_path, expected):
    """Rank 0's folder holds exactly `expected` (no partial file left); every other rank's is
    empty, and so is the temporary folder."""
    assert sorted(p.name for p in (tmp_path / "rank0").iterdir()) == sorted(expected)
    for r in range(1, RANKS):
        assert list((tmp_path / f"rank{r}").iterdir()) == [], f"rank {r} wrote"
    assert list((tmp_path / "tmp").iterdir()) == []


def _serial(argv, cwd):
    """`icidr-pde argv` in a process of its own, no launcher: (status, stdout)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMI", "PMIX", "SLURM"))}
    proc = subprocess.run([sys.executable, "-m", "icidr_pde.cli", *argv], cwd=cwd, capture_output=True, text=True,
                          env=dict(env, PYTHONPATH=str(ROOT), MPLBACKEND="Agg"), timeout=900)
    return proc.returncode, proc.stdout


TSTAR = ["tstar", "--scene", "bump2d", "--rheology", "mui", "--N", "12,16", "--t-end", "10"]


def test_tstar_of_the_2d_bump_under_mpiexec_is_the_serial_sweep(tmp_path):
    """t*(N) of mu(I) on bump2d, PETSc on 2 ranks against the serial command on the native engine
    (CVODE): the same N fail, at t* within 1e-2 relative (the engines' agreement at the preset's
    tolerances, rtol 1e-5: 5e-4 to 2.4e-3 measured at 12^2 to 24^2); the summary printed once, the
    JSON and the plot written by rank 0 alone, status 0 on every rank."""
    proc = _on_ranks(tmp_path, [*TSTAR, "--engine", "petsc", "--json", "ts.json", "--plot", "ts.png",
                                "--no-progress"])
    out, err, statuses = _finished(tmp_path, proc)
    assert proc.returncode == 0 and statuses == ["0"] * RANKS, err[-3000:]
    assert out.count("t*(N) written to ts.json") == 1 and out.count("N=  12") == 1, out
    assert "Traceback" not in err
    _only_rank0_wrote(tmp_path, ["ts.json", "ts.png"])
    document = json.loads((tmp_path / "rank0" / "ts.json").read_text())
    entry = document["discretizations"]["fv2d"]
    assert entry["settings"]["engine"] == "petsc" and entry["settings"]["rheology"] == "mui"
    (tmp_path / "serial").mkdir()
    status, _ = _serial([*TSTAR, "--engine", "native", "--json", "ts.json", "--no-progress"], tmp_path / "serial")
    assert status == 0
    serial = json.loads((tmp_path / "serial" / "ts.json").read_text())["discretizations"]["fv2d"]
    assert serial["settings"]["engine"] == "native"
    assert set(entry["t_star"]) == set(serial["t_star"]) == {"12", "16"}
    for n, t_star in serial["t_star"].items():
        assert t_star is not None and entry["t_star"][n] == pytest.approx(t_star, rel=1e-2), n


CONVERGENCE = ["study", "sim2d", "convergence", "--sizes", "8", "12", "16", "--json", "conv.json", "--no-progress"]


def test_grid_convergence_2d_under_mpiexec_is_the_serial_study(tmp_path):
    """The iCIDR 2-D grid-convergence study (bump2d, t = 0.5 .. 10) with its 2-D runs on PETSc on 2
    ranks against the serial study (CVODE, GMRES): every measure within 1e-3 relative (the PETSc
    engine against the default, as tests/test_petsc.py's t = 10 test; 7e-5 measured here at rtol
    1e-7), the observed orders of each quantity computed from them; one JSON, rank 0's."""
    proc = _on_ranks(tmp_path, [*CONVERGENCE, "--engine", "petsc"])
    out, err, statuses = _finished(tmp_path, proc)
    assert proc.returncode == 0 and statuses == ["0"] * RANKS, err[-3000:]
    assert out.count("iCIDR bump2d 16x16") == 1, out
    _only_rank0_wrote(tmp_path, ["conv.json"])
    petsc = json.loads((tmp_path / "rank0" / "conv.json").read_text())
    (tmp_path / "serial").mkdir()
    status, _ = _serial(CONVERGENCE, tmp_path / "serial")
    assert status == 0
    serial = json.loads((tmp_path / "serial" / "conv.json").read_text())
    assert petsc["settings"]["engine"] == "petsc" and "engine" not in serial["settings"]
    assert petsc["command"] == "icidr-pde study sim2d convergence --sizes 8 12 16 --engine petsc --json conv.json"
    for n in ("8", "12", "16"):
        for q in ("max_w", "max_phi_dev", "l2_velocity"):
            for t, value in serial["runs"][n][q].items():
                assert petsc["runs"][n][q][t] == pytest.approx(value, rel=1e-3), (n, q, t)
    assert set(petsc["observed_orders"]["max_w"]) == set(serial["observed_orders"]["max_w"])


@pytest.mark.parametrize("argv, named", [
    (["tstar", "--scene", "bump2d", "--engine", "petsc", "--N", "2"], "every `--N` must be in [4, "),
    (["tstar", "--scene", "bump2d", "--engine", "petsc", "--N", "8", "--json", "missing/t.json"],
     "`--json` 'missing/t.json' directory 'missing' does not exist"),
    (["tstar", "--scene", "bump2d", "--engine", "petsc", "--N", "8", "--workers", "2"],
     "`--workers` must not be given under an MPI launcher (2 processes): the ranks compute each run together, "
     "one run after the other; got --workers 2"),
    (["study", "sim2d", "convergence", "--engine", "petsc", "--json", "missing/c.json"],
     "`--json` 'missing/c.json' directory 'missing' does not exist"),
])
def test_bad_input_of_a_study_under_mpiexec_is_one_line_and_status_2_on_each(tmp_path, argv, named):
    """One line naming the parameter, its range and the value received, said once (rank 0), exit
    status 2 on every rank, nothing written, no traceback and no MPI abort. The folder is checked
    by rank 0, whose verdict every rank takes (rank 1 runs in another folder, where it would not
    exist either)."""
    proc = _on_ranks(tmp_path, argv)
    out, err, statuses = _finished(tmp_path, proc, timeout=600)
    assert proc.returncode == 2 and statuses == ["2"] * RANKS, err[-3000:]
    errors = [line for line in err.splitlines() if "error" in line.lower()]
    assert len(errors) == 1 and errors[0].startswith("icidr-pde: error:") and named in errors[0], err[-3000:]
    assert "Traceback" not in err and "MPI_ABORT" not in err and "PETSC ERROR" not in err and out == ""
    _only_rank0_wrote(tmp_path, [])


def test_sigterm_during_a_sweep_under_mpiexec_keeps_the_cases_that_finished(tmp_path):
    """SIGTERM to mpiexec while the second case of a t*(N) sweep runs (N = 16 first, fails at
    t* = 2.54; then N = 4, t* = 76 far off): every rank stops after the same step, rank 0 writes
    the JSON of the case that finished, the cache keeps it, and every rank's status is 143.
    Open MPI's mpiexec (4.1) passes SIGTERM on to the ranks only after its
    odls_base_sigkill_timeout (5 s here), so the second case is made to last longer than that on
    an idle machine (rtol 1e-9: several times the default's steps; at the default rtol it could
    end before the signal reached the ranks, and the sweep finished with status 0)."""
    env = _env(tmp_path, OMPI_MCA_odls_base_sigkill_timeout="5")  # SIGTERM to SIGKILL: 1 s by default
    proc = _on_ranks(tmp_path, ["tstar", "--scene", "bump2d", "--rheology", "mui", "--engine", "petsc", "--N", "4,16",
                                "--t-end", "200", "--rtol", "1e-9", "--atol", "1e-12", "--json", "ts.json",
                                "--cache", "cache"], env=env)
    seen, second = [], threading.Event()

    def read_progress():  # rank 0's bar: 't*(N):  50%|... 1/2 [...]'
        text = ""
        while (chunk := proc.stderr.read(1)) != "":
            text += chunk
            if not second.is_set() and re.search(r"\| 1/2 \[", text):
                second.set()
        seen.append(text)

    reader = threading.Thread(target=read_progress, daemon=True)
    reader.start()
    assert second.wait(timeout=900), "the first case did not finish"
    time.sleep(0.2)  # the second case takes seconds: the signal must land while it runs, not after it
    assert proc.poll() is None, "the second case ended before the signal"
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=300)
    reader.join(timeout=60)
    statuses = [(tmp_path / f"status.{r}").read_text() for r in range(RANKS)]
    assert statuses == ["143"] * RANKS, seen[-1][-3000:]
    assert "Traceback" not in seen[-1] and "MPI_ABORT" not in seen[-1]
    assert "interrupted after 1 of 2 cases" in seen[-1]
    entry = json.loads((tmp_path / "rank0" / "ts.json").read_text())["discretizations"]["fv2d"]
    assert list(entry["t_star"]) == ["16"] and entry["t_star"]["16"] == pytest.approx(2.54, rel=1e-2)
    assert len(list((tmp_path / "rank0" / "cache").glob("*.json"))) == 1
    assert list((tmp_path / "rank1").iterdir()) == []


# --- the Slurm job scripts, run here with mpiexec in place of srun ---------------------------------------

SLURM = ROOT / "docs" / "slurm"


def srun_command(script: Path, ranks: int) -> str:
    """The script's `srun ...` command line (continuation lines joined) with srun and its options
    replaced by PETSc's `mpiexec -q -n RANKS --oversubscribe`, and `icidr-pde` by this Python's
    ``-m icidr_pde.cli`` (the command of this checkout)."""
    text = script.read_text().replace("\\\n", " ")
    lines = [line.strip() for line in text.splitlines() if line.strip().startswith("srun ")]
    assert len(lines) == 1, f"{script.name} must hold one srun command line; got {lines}"
    words = shlex.split(lines[0], posix=False)
    k = 1
    while words[k].startswith("-"):  # srun's own options
        k += 1
    assert words[k] == "icidr-pde", words
    launcher = f"{shlex.quote(MPIEXEC)} -q --oversubscribe -n {ranks} {shlex.quote(sys.executable)} -m icidr_pde.cli"
    return " ".join([launcher, *words[k + 1:]])


def _run_job_line(tmp_path, script, variables):
    """The script's variables (its defaults overridden by `variables`, as `VAR=... sbatch` does)
    and its srun line under mpiexec -n 2, in tmp_path: the CompletedProcess."""
    text = script.read_text()
    assignments = [line for line in text.splitlines() if re.match(r"^[A-Z_]+=\"?\$\{[A-Z_]+:-", line)]
    body = "\n".join(["set -euo pipefail", *assignments, srun_command(script, RANKS)])
    env = _env(tmp_path, SLURM_JOB_ID="test", **variables)
    return subprocess.run(["bash", "-c", body], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)


def test_slurm_scripts_hold_one_srun_line_of_a_study_on_petsc():
    for name in ("tstar2d.sbatch", "grid_convergence2d.sbatch"):
        command = srun_command(SLURM / name, RANKS)
        assert "--engine petsc" in command and "--json" in command, command
        assert (SLURM / name).read_text().startswith("#!/bin/bash\n#SBATCH ") or "#SBATCH" in (SLURM / name).read_text()


def test_tstar2d_job_script_under_mpiexec(tmp_path):
    """docs/slurm/tstar2d.sbatch's command line, srun replaced by mpiexec -n 2, at N = 12, 16: the
    JSON, the plot and the cache of rank 0, t* of both grids (fails before t = 10)."""
    proc = _run_job_line(tmp_path, SLURM / "tstar2d.sbatch", {"N": "12,16", "T_END": "10"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    entry = json.loads((tmp_path / "tstar2d_test.json").read_text())["discretizations"]["fv2d"]
    assert entry["settings"]["engine"] == "petsc" and set(entry["t_star"]) == {"12", "16"}
    assert all(t is not None and 0 < t < 10 for t in entry["t_star"].values())
    assert (tmp_path / "tstar2d_test.png").stat().st_size > 0
    assert len(list((tmp_path / "tstar2d_cache").glob("*.json"))) == 2
    assert proc.stdout.count("t*(N) written to") == 1


def test_grid_convergence2d_job_script_under_mpiexec(tmp_path):
    """docs/slurm/grid_convergence2d.sbatch's command line under mpiexec -n 2 at 8^2, 12^2, 16^2: the
    study's JSON (runs, observed orders) written once, by rank 0."""
    proc = _run_job_line(tmp_path, SLURM / "grid_convergence2d.sbatch", {"SIZES": "8 12 16"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    payload = json.loads((tmp_path / "convergence2d_test.json").read_text())
    assert payload["sizes"] == [8, 12, 16] and payload["settings"]["engine"] == "petsc"
    assert all(not payload["runs"][n]["blew_up"] for n in ("8", "12", "16"))
    assert len(payload["observed_orders"]["max_w"]["10"]) == 1
    assert proc.stdout.count("iCIDR bump2d 16x16") == 1
