"""The documentation site builds with warnings as errors (docs/conf.py; ``pip install -e ".[docs]"``).

A warning is a broken page: a link to a page or section that is not there, a page in no table of
contents, a module the API reference cannot import. The build runs in its own process, as a
user's ``sphinx-build -W --keep-going -b html docs OUT`` does, so that its imports of every module
stay out of the test process.
"""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MISSING = [name for name in ("sphinx", "myst_parser", "myst_nb") if importlib.util.find_spec(name) is None]


@pytest.mark.skipif(bool(MISSING), reason=f"the site needs the [docs] extra (pip install -e \".[docs]\"); "
                                          f"not installed: {', '.join(MISSING)}")
def test_site_builds_without_a_warning(tmp_path):
    out = tmp_path / "html"
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(tmp_path / "doctrees"), str(DOCS), str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert build.returncode == 0 and not build.stderr.strip(), (
        f"sphinx-build exit {build.returncode}:\n{build.stderr[-6000:]}")
    # the pages a reader starts from, and the API reference generated from the packages
    assert (out / "index.html").is_file() and (out / "results.html").is_file()
    assert (out / "api" / "icidr_pde" / "icidr_pde.html").is_file()
    assert "in module icidr_pde." in (out / "genindex.html").read_text()
    assert (out / "getting_started.html").is_file()
    # every notebook is a tutorial page showing its code as stored (cleared: the build runs no
    # kernel, so no output appears)
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        html = (out / "tutorials" / f"{notebook.stem}.html").read_text()
        assert "cell_output" not in html, notebook.name
    assert "plot_max_w" in (out / "tutorials" / "quickstart.html").read_text()
    index = (out / "index.html").read_text()
    first = index.index('href="tutorials/quickstart.html"')
    assert all(first < index.index(f'href="tutorials/{n.stem}.html"')
               for n in (ROOT / "notebooks").glob("*.ipynb") if n.stem != "quickstart"), "quickstart first"
    # a page per benchmark file the renderer places, the others listed (tests/test_benchmark_pages.py)
    measurements = (out / "measurements" / "index.html").read_text()
    for data in sorted((ROOT / "data" / "benchmarks").glob("*.json*")):
        assert (out / "measurements" / f"{data.stem}.html").is_file() or \
            f"data/benchmarks/{data.name}" in measurements, data.name


@pytest.mark.skipif(bool(MISSING), reason=f"the site needs the [docs] extra (pip install -e \".[docs]\"); "
                                          f"not installed: {', '.join(MISSING)}")
def test_a_broken_link_fails_the_build(tmp_path):
    """The flags above turn a warning into a failure: a page linking to a page that is not there."""
    (tmp_path / "src").mkdir()
    (tmp_path / "src" / "conf.py").write_text('extensions = ["myst_parser"]\n')
    (tmp_path / "src" / "index.md").write_text("# Index\n\n[a page](missing.md)\n")
    build = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         str(tmp_path / "src"), str(tmp_path / "html")], capture_output=True, text=True, timeout=300)
    assert build.returncode != 0 and "missing" in build.stderr
