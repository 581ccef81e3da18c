"""``tstar``'s default settings (``--accuracy stated``) meet the accuracy stated for a t*, and
``--accuracy paper`` keeps the paper's.

Truth: data/tstar/tstar_accuracy.json (benchmarks/tstar_accuracy.py): the converged Chebyshev t*
of another linear solver at tolerances a thousand times tighter (CVODE's dense LU, rtol 1e-10),
itself checked against the BDF rtol 1e-10 reference of data/reference (another integrator); the
finite-volume reference and scatter of band LU runs at rtol 1e-9..1e-11. The paper's settings'
anchor: scipy's BDF t* of Chebyshev N = 201 (tests/test_distributed.py's anchor, bit for bit).
A few N only: those on either side of both thresholds and two of the large N.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from icidr_pde import cli
from icidr_pde.datafiles import data_dir
from icidr_pde.studies.failure_time import ACCURACY, sweep_settings
from icidr_pde.studies.references import reference_tstar

#: scipy's BDF, rtol 1e-6, atol 1e-9, numpy right-hand side: Chebyshev N = 201 (tests/test_distributed.py)
ANCHOR_TSTAR_CHEB_201 = 0.010581191657354078
NS = (55, 57, 59, 61, 121, 201)


@pytest.fixture(scope="module")
def measured():
    return json.loads((data_dir() / "tstar" / "tstar_accuracy.json").read_text())


@pytest.fixture(scope="module")
def default_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("stated") / "t.json"
    argv = ["tstar", "--discretization", "fd", "cheb", "--N", ",".join(map(str, NS)), "--jobs", "1",
            "--no-progress", "--json", str(out)]
    assert cli.main(argv) == 0
    return json.loads(out.read_text())["discretizations"]


def test_the_converged_chebyshev_tstar_is_the_reference_of_another_integrator(measured):
    converged = measured["cheb"]["converged"]["201"]
    assert converged == pytest.approx(reference_tstar("cheb")["t_star"], rel=1e-6)
    assert max(measured["cheb"]["converged_error"].values()) < 1e-4  # rtol 1e-9 against 1e-10


def test_the_default_chebyshev_tstar_is_within_1e_3_of_the_converged(default_sweep, measured):
    entry = default_sweep["cheb"]
    assert {k: entry["settings"][k] for k in ("engine", "method", "rtol", "atol")} == ACCURACY["stated"]["cheb"]
    converged = measured["cheb"]["converged"]
    for n, t in entry["t_star"].items():
        if converged[n] is None:
            assert t is None, n
        else:
            assert t == pytest.approx(converged[n], rel=1e-3), n
    assert entry["t_star"]["55"] is None and entry["t_star"]["57"] is not None  # the paper's threshold


def test_the_default_finite_volume_tstar_is_within_its_stated_scatter(default_sweep, measured):
    entry = default_sweep["fd"]
    assert {k: entry["settings"][k] for k in ("engine", "method", "rtol", "atol")} == ACCURACY["stated"]["fd"]
    reference, bound = measured["fd"]["reference"], measured["fd"]["accuracy"]
    for n in ("121", "201"):
        assert entry["t_star"][n] == pytest.approx(reference[n], rel=bound[n]), n
    assert entry["t_star"]["59"] is None and entry["t_star"]["61"] is not None  # the paper's threshold
    assert entry["t_star"]["61"] == pytest.approx(reference["61"], rel=measured["fd"]["scatter_all"]["61"])


def test_the_measurement_chose_the_default(measured):
    """The stated settings are those benchmarks/tstar_accuracy.py found cheapest among those meeting
    the accuracy (the file's candidates are named by linear solver and rtol)."""
    for disc, label in measured["cheapest"].items():
        row = measured["candidates"][label]
        assert row["meets"] and row["rtol"] == ACCURACY["stated"][disc]["rtol"]


def test_paper_accuracy_is_the_papers_bdf_bit_for_bit(tmp_path):
    # a process of its own with BLAS's own thread count, as a user's command: the anchor's last bits
    # are those of the dense LU with OpenBLAS's default threads (one thread, as a sweep's workers and
    # a test worker after a sweep set it, gives 0.010581191657365971, 1.1e-12 relative away)
    out = tmp_path / "paper.json"
    command = [sys.executable, "-m", "icidr_pde.cli", "tstar", "--accuracy", "paper", "--discretization", "cheb",
               "--N", "201", "--t-end", "20", "--jobs", "1", "--no-progress", "--json", str(out)]
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    assert subprocess.run(command, capture_output=True, env=env).returncode == 0
    entry = json.loads(out.read_text())["discretizations"]["cheb"]
    assert entry["settings"]["engine"] == "scipy" and entry["settings"]["method"] == "BDF"
    assert (entry["settings"]["rtol"], entry["settings"]["atol"]) == (1e-6, 1e-9)
    assert entry["t_star"]["201"] == ANCHOR_TSTAR_CHEB_201


@pytest.mark.parametrize("given, expected", [
    (dict(), dict(engine="native", method="CVODE", rtol=1e-7, atol=1e-10)),
    (dict(engine="pde"), dict(engine="pde", method="BDF", rtol=1e-6, atol=1e-9)),
    (dict(method="Radau"), dict(engine="pde", method="Radau", rtol=1e-6, atol=1e-9)),
    (dict(rtol=1e-9), dict(engine="native", method="CVODE", rtol=1e-9, atol=1e-10)),
])
def test_options_given_take_the_place_of_the_accuracys(given, expected):
    assert sweep_settings("stated", "cheb", **given) == expected
    with pytest.raises(ValueError, match="`accuracy` must be one of"):
        sweep_settings("exact", "cheb")
