"""``--json /dev/stdout`` gives a stream a JSON reader can take: the run's summary goes to stderr
then, and a native run that ends at the minimum step prints no SUNDIALS warnings.

CVODE warns "t + h = t on the next step" (up to ten times) before its step size underflows; on
stdout those lines broke the JSON. Chebyshev N = 801 at rtol 1e-8 reaches them (steps of 1e-19
just before t*)."""

import json
import subprocess
import sys

import pytest

RUN = [sys.executable, "-m", "icidr_pde.cli", "run", "--rheology", "mui", "--scene", "shear", "--no-progress"]


def test_json_on_stdout_is_the_whole_of_stdout():
    proc = subprocess.run(RUN + ["--N", "51", "--t-end", "0.01", "--json", "/dev/stdout"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["reason"] == "reached t_end"
    assert "Result(mui" in proc.stderr  # the summary is still shown


def test_with_json_to_a_file_the_summary_stays_on_stdout(tmp_path):
    proc = subprocess.run(RUN + ["--N", "51", "--t-end", "0.01", "--json", str(tmp_path / "r.json")],
                          capture_output=True, text=True)
    assert proc.returncode == 0 and "Result(mui" in proc.stdout and "json written to" in proc.stdout


@pytest.mark.slow
def test_a_run_ending_at_the_minimum_step_prints_no_solver_warnings():
    proc = subprocess.run(RUN + ["--discretization", "cheb", "--N", "801", "--rtol", "1e-8", "--atol", "1e-11",
                                 "--t-end", "1", "--json", "/dev/stdout"], capture_output=True, text=True)
    assert "t + h = t" not in proc.stdout + proc.stderr
    result = json.loads(proc.stdout)
    assert result["blew_up"] and "hmin" in result["reason"]
