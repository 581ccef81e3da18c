"""Regression tests of issue 42 ("Hardening, round 3"), items 4 and 12-19: inputs refused before
any work with one line naming the option, memory estimated before allocating, an interrupted
sweep keeping what finished, and a kernel cache cleared under a running compile.

Each test reproduces one defect through the command line (``icidr_pde.cli.main`` in process,
or ``python -m icidr_pde.cli`` as a subprocess where a signal or the exit status is the point)
or the public API.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from icidr_pde import cli
from icidr_pde.validation import MEMORY_ENV, ParameterError

ROOT = Path(__file__).resolve().parents[1]


def refused(capsys, *argv) -> str:
    """The one line with which the command line refuses `argv` (exit 2, no traceback)."""
    status = cli.main(list(argv))
    err = capsys.readouterr().err
    assert status == cli.EXIT_BAD_INPUT, err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.startswith(cli.PREFIX)]
    assert len(lines) == 1, err
    return lines[0]


# --- 12. the memory override ----------------------------------------------------------------


@pytest.mark.parametrize("value", ["inf", "1e400", "-1", "0", "nan", "lots"])
def test_memory_override_out_of_range_is_refused(value, monkeypatch, capsys):
    """$ICIDR_PDE_MEMORY=inf or 1e400 used to raise OverflowError (a traceback) in int(inf)."""
    monkeypatch.setenv(MEMORY_ENV, value)
    line = refused(capsys, "run", "--t-end", "0.1", "--no-progress")
    assert f"`${MEMORY_ENV}` must be a finite number of bytes > 0; got {value!r}" in line


# --- 15. t_end too small to have an output ------------------------------------------------


@pytest.mark.parametrize("t_end", ["1e-300", "5e-324", "1e-9"])
def test_t_end_below_the_time_resolution_is_refused(t_end, capsys):
    """--t-end 1e-300 used to raise IndexError after the run (no output time but t = 0); 5e-324
    said "Geometric sequence cannot include zero" without naming the option."""
    line = refused(capsys, "run", "--t-end", t_end, "--no-progress")
    assert "`--t-end` must be a finite number in [1e-08, 1e+15]" in line


def test_t_end_at_the_smallest_allowed_reaches_it(capsys):
    """The bound refuses no run that works: t_end = 1e-8 reaches t_end."""
    from icidr_pde import run

    result = run("icidr", "shear", 21, 1e-8)
    assert not result.blew_up and result.t_final == pytest.approx(1e-8)


# --- 16. an empty output path ---------------------------------------------------------------


@pytest.mark.parametrize("option", ["--json", "--plot", "--save"])
def test_empty_output_path_is_refused_before_the_run(option, tmp_path, monkeypatch, capsys):
    """`run --json ''` used to run and then fail to write (exit 4); `--plot ''` was called a directory."""
    monkeypatch.chdir(tmp_path)
    line = refused(capsys, "run", "--t-end", "0.1", "--no-progress", option, "")
    assert line.endswith(f"`{option}` must be a file path; got ''")
    assert "Geometric" not in line and list(tmp_path.iterdir()) == []
