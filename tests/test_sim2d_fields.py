"""The field images and movie of docs/sim2d.md (``icidr-pde figures sim2d-fields``): written where asked,
from arguments, whole."""

import subprocess
import sys

import numpy as np
import pytest

from icidr_pde.cli import main


def test_a_missing_output_folder_is_one_line_and_exit_2(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "figures", "sim2d-fields", "--out",
                           str(tmp_path / "nowhere")],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "--out" in proc.stderr and "nowhere" in proc.stderr and "Traceback" not in proc.stderr


def test_a_grid_below_its_range_names_the_range(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "icidr_pde.cli", "figures", "sim2d-fields", "--out", str(tmp_path),
                           "--N", "2"],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and ">= 8" in proc.stderr and "'2'" in proc.stderr


@pytest.mark.slow
def test_the_figure_and_the_movie_are_written_into_the_folder_asked(tmp_path):
    from PIL import Image

    assert main(["figures", "sim2d-fields", "--out", str(tmp_path), "--N", "8", "--movie-N", "8", "--frames", "3"]) == 0
    with Image.open(tmp_path / "sim2d_fields.png") as image:
        assert image.size[0] > 300 and np.asarray(image).std() > 0  # drawn, not blank
    movie = tmp_path / "sim2d.mp4"
    assert movie.read_bytes()[4:8] == b"ftyp"  # an MP4 container, renamed only when complete
    assert not [p for p in tmp_path.iterdir() if p.name not in ("sim2d_fields.png", "sim2d.mp4")]
