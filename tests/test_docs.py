"""The documentation site builds with warnings as errors (docs/conf.py; ``pip install -e ".[docs]"``).

A warning is a broken page: a link to a page or section that is not there, a page in no table of
contents, a module the API reference cannot import. The build runs in its own process, as a
user's ``sphinx-build -W --keep-going -b html docs OUT`` does, so that its imports of every module
stay out of the test process.
"""

import importlib.util
import os
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
    build = _build(tmp_path, "off")
    assert build.returncode == 0 and not build.stderr.strip(), (
        f"sphinx-build exit {build.returncode}:\n{build.stderr[-6000:]}")
    # the pages a reader starts from, and the API reference generated from the packages
    assert (out / "index.html").is_file() and (out / "results.html").is_file()
    assert (out / "api" / "icidr_pde" / "icidr_pde.html").is_file()
    assert "in module icidr_pde." in (out / "genindex.html").read_text()
    assert (out / "getting_started.html").is_file()
    # every notebook is a tutorial page showing its code as stored (cleared: this build runs no
    # kernel, so no output appears), and saying so
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        html = (out / "tutorials" / f"{notebook.stem}.html").read_text()
        assert "cell_output" not in html, notebook.name
        assert "shown as stored, without its outputs" in html if notebook.name == "workbench.ipynb" else \
            "This build of the site did not run the notebooks" in html, notebook.name
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


def _build(tmp_path, execute: str, cache=None):
    """sphinx-build -W of docs/ into tmp_path/html, the notebooks run (``cache``) or not (``off``)."""
    env = {**os.environ, "ICIDR_PDE_DOCS_EXECUTE": execute}
    if cache is not None:
        env["ICIDR_PDE_DOCS_CACHE"] = str(cache)
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")],
        cwd=ROOT, capture_output=True, text=True, timeout=3600, env=env)


@pytest.mark.slow
@pytest.mark.skipif(bool(MISSING), reason=f"the site needs the [docs] extra (pip install -e \".[docs]\"); "
                                          f"not installed: {', '.join(MISSING)}")
def test_the_published_site_shows_the_outputs_of_the_notebooks(tmp_path):
    """The build a reader's site comes from runs the notebooks in a kernel (cached): each tutorial
    page shows the outputs of its cells, figures included; workbench.ipynb's is shown as stored
    and says why."""
    build = _build(tmp_path, "cache", cache=tmp_path / "jupyter_cache")
    # ipykernel's note that nbclient's kernels talk over local TCP is no warning of the build
    stderr = "\n".join(line for line in build.stderr.splitlines()
                       if not line.startswith("[IPKernelApp] WARNING | Kernel is running over TCP"))
    assert build.returncode == 0 and not stderr.strip(), stderr[-6000:]
    out = tmp_path / "html" / "tutorials"
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        html = (out / f"{notebook.stem}.html").read_text()
        if notebook.name == "workbench.ipynb":
            assert "cell_output" not in html and "the site's build does not run it" in html
        else:
            assert "cell_output" in html and "did not run the notebooks" not in html, notebook.name
    assert "<img" in (out / "quickstart.html").read_text()  # its figures, drawn by the kernel


@pytest.mark.skipif(bool(MISSING), reason=f"the site needs the [docs] extra (pip install -e \".[docs]\"); "
                                          f"not installed: {', '.join(MISSING)}")
def test_a_build_that_would_run_the_notebooks_some_other_way_is_refused(tmp_path):
    build = _build(tmp_path, "force")
    assert build.returncode != 0
    assert "ICIDR_PDE_DOCS_EXECUTE must be 'cache' or 'off'; got 'force'" in build.stderr


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
