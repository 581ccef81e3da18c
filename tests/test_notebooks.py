"""Every notebook runs top to bottom in a Jupyter kernel (nbclient), one test per notebook.

The notebooks are stored with their outputs cleared: the suite executes them anyway, outputs
would go stale with every change of the code and bloat every diff, and the figures they draw
are committed once, in docs/figures/. The kernel gets ICIDR_PDE_DRAFT=1 (N = 101 instead of
201: the same findings, a fraction of the cost) and the inline matplotlib backend a user has.
A failing cell fails the test (nbclient raises CellExecutionError with the cell's traceback).
"""

import os
import pathlib

import pytest

NOTEBOOK_DIR = pathlib.Path(__file__).resolve().parent.parent / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")


def _execute(path):
    book = nbformat.read(path, as_version=4)
    env = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"}
    env["ICIDR_PDE_DRAFT"] = "1"
    client = nbclient.NotebookClient(book, timeout=900, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK_DIR)}})
    client.execute(env=env)
    return book


# the workbench notebook takes ~70 s even in draft mode (its symbolic checks of four laws), the 2-D
# one ~20-30 s (its runs of both rheologies): kept to the slow run so that the default run stays
# within CI's ten minutes on 2 cores; what they show is tested in tests/workbench/ and by the 2-D
# tests (test_figures2d.py, test_sim2d_fields.py, test_cartesian2d.py)
SLOW_NOTEBOOKS = {"workbench.ipynb", "6_two_dimensional.ipynb"}


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.name in SLOW_NOTEBOOKS else p
                                  for p in NOTEBOOKS], ids=[p.name for p in NOTEBOOKS])
def test_notebook(path):
    book = _execute(path)
    for cell in book.cells:
        if "live-plot" in cell.metadata.get("tags", []):
            images = [o for o in cell.outputs if o.get("output_type") in ("display_data", "update_display_data")
                      and "image/png" in o.get("data", {})]
            runs = cell.source.count("live_plot=True")
            # one live figure per run, replaced in place (update_display_data edits it, adds no output)
            assert len([o for o in images if o["output_type"] == "display_data"]) == runs, cell.outputs
            assert not any("<Figure size" in o.get("data", {}).get("text/plain", "") for o in cell.outputs
                           if "image/png" not in o.get("data", {}))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_is_stored_cleared(path):
    book = nbformat.read(path, as_version=4)
    for cell in book.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: clear outputs before committing"
