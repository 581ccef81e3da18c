"""Every module the tests and notebooks import is declared: a fresh install of the README's
extras brings it, whatever else the machine happens to have installed.

The closure of ``icidr-pde[test,dem]``'s requirements is read from the installed metadata
(importlib.metadata), and each imported top-level module must come from a distribution in it.
"""

import ast
import json
import re
import shutil
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LOCAL = {"icidr_pde", "stability", "tests", "conftest", "end_to_end"}  # this repository's own


def _name(requirement: str) -> tuple[str, set[str], str]:
    """(normalised name, extras, marker) of a requirement string."""
    head, _, marker = requirement.partition(";")
    m = re.match(r"\s*([A-Za-z0-9_.\-]+)\s*(\[([^\]]*)\])?", head)
    extras = {e.strip() for e in (m.group(3) or "").split(",") if e.strip()}
    return re.sub(r"[-_.]+", "-", m.group(1)).lower(), extras, marker


def _closure(name: str, extras: set[str]) -> set[str]:
    seen: set[str] = set()
    todo = [(name, frozenset(extras))]
    while todo:
        dist_name, wanted = todo.pop()
        key = f"{dist_name}{sorted(wanted)}"
        if key in seen:
            continue
        seen.add(key)
        try:
            requires = metadata.requires(dist_name) or []
        except metadata.PackageNotFoundError:
            continue  # an optional requirement whose marker excludes this machine
        for req in requires:
            req_name, req_extras, marker = _name(req)
            extra = re.search(r"extra\s*==\s*['\"]([^'\"]+)['\"]", marker)
            if extra and extra.group(1) not in wanted:
                continue
            if marker and not extra:
                from packaging.markers import Marker
                if not Marker(marker).evaluate():
                    continue
            todo.append((req_name, frozenset(req_extras)))
    return {k.split("[")[0] for k in seen}


def _imports(source: str) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def _imported_by_tests_and_notebooks() -> dict[str, str]:
    where = {}
    for path in sorted((ROOT / "tests").rglob("*.py")):
        for name in _imports(path.read_text()):
            where.setdefault(name, str(path.relative_to(ROOT)))
    for path in sorted((ROOT / "notebooks").glob("*.ipynb")):
        for cell in json.loads(path.read_text())["cells"]:
            if cell["cell_type"] == "code":
                source = "\n".join(line for line in "".join(cell["source"]).splitlines()
                                   if not line.lstrip().startswith(("%", "!")))
                for name in _imports(source):
                    where.setdefault(name, str(path.relative_to(ROOT)))
    return where


def test_every_imported_module_comes_from_a_declared_requirement():
    declared = _closure("icidr-pde", {"test", "dem"})
    providers = metadata.packages_distributions()
    missing = []
    for module, where in sorted(_imported_by_tests_and_notebooks().items()):
        if module in sys.stdlib_module_names or module in LOCAL or module.startswith("_"):
            continue
        dists = {re.sub(r"[-_.]+", "-", d).lower() for d in providers.get(module, [])}
        if not dists & declared:
            missing.append(f"{module} (imported by {where}; from {sorted(dists) or 'nothing installed'})")
    assert not missing, "imported but declared by no extra of [test,dem]: " + "; ".join(missing)


@pytest.mark.parametrize("command", [["lab", "--version"], ["nbconvert", "--version"]])
def test_the_notebook_extra_gives_a_jupyter_front_end(command):
    jupyter = shutil.which("jupyter", path=str(Path(sys.executable).parent))
    assert jupyter, "no `jupyter` next to this interpreter: [notebook] must bring JupyterLab"
    proc = subprocess.run([jupyter, *command], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-1000:]
