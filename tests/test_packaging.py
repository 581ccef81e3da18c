"""The wheel ships every package and the committed results the code reads (data/)."""

import fnmatch
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _setuptools():
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def test_explicit_package_list_covers_every_package():
    found = {str(p.parent.relative_to(ROOT)).replace(os.sep, ".")
             for top in ("icidr_pde", "stability") for p in (ROOT / top).rglob("__init__.py")}
    assert found <= set(_setuptools()["packages"])


def test_every_committed_result_is_package_data():
    st = _setuptools()
    assert st["package-dir"]["icidr_pde.data"] == "data"
    patterns = st["package-data"]["icidr_pde.data"]
    files = [str(p.relative_to(ROOT / "data")) for p in (ROOT / "data").rglob("*")
             if p.is_file() and "cache" not in p.parts and not p.name.startswith(".")]
    missing = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert files and not missing, f"data files not shipped: {missing}"


def test_source_tree_reads_its_own_data():
    from icidr_pde.datafiles import data_dir
    from icidr_pde.dem.paths import committed

    assert data_dir() == ROOT / "data"
    assert committed("steady.json").is_file()
    with pytest.raises(FileNotFoundError, match="nope.json"):
        committed("nope.json")


@pytest.mark.slow
def test_non_editable_install_finds_the_data_outside_the_repository(tmp_path):
    """Build the wheel, install it (no dependencies) into a directory, import it from elsewhere."""
    wheel_dir, site = tmp_path / "wheel", tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(wheel_dir),
                    str(ROOT)], check=True)
    whl = next(wheel_dir.glob("*.whl"))
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(site),
                    str(whl)], check=True)
    code = ("import icidr_pde, icidr_pde.studies.references as r\n"
            "from icidr_pde.dem.paths import committed\n"
            "import json\n"
            f"assert icidr_pde.__file__.startswith({str(site)!r}), icidr_pde.__file__\n"
            "assert (r.REFERENCE_DIR / 'icidr-sine.npz').is_file(), r.REFERENCE_DIR\n"
            "assert 'fit' in json.loads(committed('steady.json').read_text())\n"
            "import icidr_pde.native.build as b\n"  # the native engine's C sources are package data
            "assert b._template() and b._text('cvode_driver.c') and b._text('sundials_api.h')\n"
            "from icidr_pde.cells import cells\n"  # and each cell's compiled problems
            "assert b._text('problem.h') and all(c.problem_source() for c in cells().values())\n"
            "print('ok')\n")
    env = {**os.environ, "PYTHONPATH": str(site)}
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert out.returncode == 0 and "ok" in out.stdout, out.stderr
