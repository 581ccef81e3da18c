"""The cells' registry (icidr_pde.cells): each descriptor against the schemes, scenes, laws,
templates and engines it names, the look-ups that replace tests of a dimension, and the rule
that a cell's modules never import another cell."""

import dataclasses

import numpy as np
import pytest

from icidr_pde.cells import CELLS, PACKAGES, cell_for, cell_of, cell_of_result, cells, get_cell
from icidr_pde.cells.base import Template
from icidr_pde.discretizations.registry import SCHEMES
from icidr_pde.scenes import SCENES

from .test_import_graph import import_graph


def test_the_registry_holds_both_cells():
    assert set(cells()) == {"shear1d", "plane2d"} == set(PACKAGES)
    assert {c.dim for c in CELLS.values()} == {1, 2}
    assert get_cell("plane2d") is CELLS["plane2d"]
    with pytest.raises(ValueError, match="`cell` must be one of"):
        get_cell("cube3d")


@pytest.mark.parametrize("name", PACKAGES)
def test_each_descriptor_is_consistent(name):
    from icidr_pde import rheology
    from icidr_pde.engines.choose import JacobianStructure
    from icidr_pde.engines.linear import LinearSolver, compiled_solver

    cell = get_cell(name)
    assert cell.name == name and cell.package == f"icidr_pde.cells.{name}" and cell.folder.is_dir()
    assert len(cell.grid_axes) == cell.dim
    # its schemes are registered, of its dimension, and no other cell claims them
    assert cell.schemes and all(SCHEMES[s].dim == cell.dim for s in cell.schemes)
    assert all(cell_of(s) is cell for s in cell.schemes)
    # its scenes are registered, of its dimension, in the module it names
    assert cell.scenes and all(getattr(SCENES[s], "dim", 1) == cell.dim for s in cell.scenes)
    assert all(cell_of(s) is cell for s in cell.scenes)
    assert any(SCENES[s].__module__ == cell.scenes_module for s in cell.scenes)
    # its laws' kinematics exists
    kinematics = {k.name: k for k in (rheology.SHEAR_CELL, rheology.PLANE_FLOW)}
    assert cell_of(kinematics[cell.kinematics]) is cell
    # its compiled templates exist, and the schemes' cores and adapters read the same files
    assert cell.templates and all(isinstance(t, Template) and (cell.folder / t.path).is_file() for t in cell.templates)
    assert all(text.lstrip().startswith('"""') for text in cell.template_texts())
    # its Jacobian structures are the engines' flags, and its native engine's modes and linear solvers theirs
    fields = {f.name for f in dataclasses.fields(JacobianStructure)}
    assert set(cell.jacobian) == set(cell.schemes) and all(set(flags) <= fields for flags in cell.jacobian.values())
    assert set(cell.native) <= set(cell.schemes) and set(cell.native_problems) == set(cell.native)
    assert set(cell.native_cores) <= set(cell.native)
    for scheme, (mode, *kind) in cell.native.items():
        assert isinstance(compiled_solver(*kind), LinearSolver) and mode in ("analytic", "krylov")
        assert callable(cell.native_problem(scheme))
        core = cell.native_core(scheme)
        assert core is None or (core.name == scheme and core.dim == cell.dim)
    # what its Result adds are the Result's fields
    from icidr_pde.result import Result

    assert set(cell.result_fields) <= {f.name for f in dataclasses.fields(Result)}


def test_the_descriptors_structures_are_what_the_schemes_offer():
    """The Jacobian structure a descriptor states, against the real scheme on a small grid."""
    from icidr_pde.case import build_case
    from icidr_pde.engines.choose import JacobianStructure

    for name, scene, N in (("fd", "shear", 9), ("cheb", "shear", 9), ("fv2d", "bump2d", (6, 5))):
        case = build_case("icidr", scene, name, N)
        assert JacobianStructure.of(case.pde, case.state) == JacobianStructure(**cell_of(name).jacobian[name])


def test_look_ups():
    from icidr_pde.rheology import PLANE_FLOW, SHEAR_CELL
    from icidr_pde.scenes import get_scene

    plane, shear = get_cell("plane2d"), get_cell("shear1d")
    assert cell_of("fv2d") is cell_of("bump2d") is cell_of(PLANE_FLOW) is cell_of(get_scene("mode2d")) is plane
    assert cell_of("fd") is cell_of("cheb") is cell_of("sine") is cell_of(SHEAR_CELL) is shear
    assert cell_of("nothing", default=None) is None
    with pytest.raises(ValueError, match="no cell"):
        cell_of("nothing")

    class Custom:  # a scheme the registry does not know: the cell of its dimension
        name, dim = "custom", 2

    assert cell_of(Custom()) is plane
    # a pair (Nx, Nz) is a 2-D grid whatever the scene; else the scene's cell (an unknown one: 1-D)
    assert cell_for("shear", (8, 8)) is plane and cell_for("bump2d", 8) is plane
    assert cell_for("shear", 8) is shear and cell_for(None, 8) is shear and cell_for("no such scene", 8) is shear


def test_grid_words_and_choice_grid():
    plane, shear = get_cell("plane2d"), get_cell("shear1d")
    assert shear.grid_words((201,)) == "`N` = 201"
    assert plane.grid_words((64, 32)) == "`Nx` x `Nz` = 64 x 32"
    assert shear.choice_grid("shear", 201) == {}
    assert plane.choice_grid("bump2d", 64) == {"cells": 64 * 64, "thin_cell": False}
    # L = 30 over 8 cells against H = 0.3 over 8: hx = 3.75 > 10 hz = 0.375
    assert plane.choice_grid("bump2d", 8, {"H": 0.3}) == {"cells": 64, "thin_cell": True}
    assert plane.choice_grid("bump2d", 3) == {}  # invalid N: the case builder says why


def test_native_refusal():
    """Plane2D.native_refusal says what choose's 2-D test said before the cells (its texts, written
    here), and choice_asks counts the grid's size on 'auto' only."""
    from icidr_pde.cells import choice_asks

    plane = get_cell("plane2d")
    thin = "a thin 2-D cell (hx > THIN_CELL hz: the py-pde path preconditions GMRES)"
    large = "a 2-D grid of 4097 cells (> 4096: the py-pde path measured faster; --engine native takes it)"
    assert plane.native_auto_cells == 64 * 64
    for thin_cell, n, said in ((True, None, thin), (False, None, ""), (False, 64 * 64, ""), (False, 64 * 64 + 1, large),
                               (True, 10**6, thin)):
        assert plane.native_refusal(thin_cell, n) == said
    assert get_cell("shear1d").native_refusal(True, 10**9) == ""
    assert choice_asks("fv2d", cells=64 * 64 + 1)["native_refusal"] == large
    assert choice_asks("fv2d", request="native", cells=64 * 64 + 1)["native_refusal"] == ""
    assert choice_asks("fd", plane, cells=64)["native_refusal"] == "a 2-D grid for discretization 'fd'"
    assert choice_asks("fd")["native"] == get_cell("shear1d").native["fd"] and choice_asks("upwind3")["native"] is None


@pytest.mark.parametrize("scheme, scene, N, z_points", [("fd", "shear", 9, 9), ("cheb", "sine", 9, 9),
                                                          ("fv2d", "bump2d", (6, 5), 5)])
def test_a_case_asks_its_cell_for_grid_state_and_points(scheme, scene, N, z_points):
    """The py-pde grid and state a core's case makes through its cell (make_grid, make_state) are
    those the py-pde path builds itself; points_along_z is the Result's N."""
    from icidr_pde.case import Case, build_case, make_pde
    from icidr_pde.native_case import core_class

    on_core = build_case("icidr", scene, scheme, N, core=core_class(scheme))
    assert on_core.scheme is not None and on_core.cell is cell_of(scheme)
    # the py-pde path's grid and state, as build_case writes them
    pde = make_pde("icidr", scheme)
    grid = pde.make_grid(N, on_core.scene.H, **getattr(on_core.scene, "grid_options", dict)())
    state = pde.make_state(grid, *on_core.scene.initial_condition(pde.nodes(grid)))
    on_pde = Case(on_core.scene, pde=pde, grid=grid, state=state)
    assert on_core.N == on_pde.N == z_points
    assert on_core.grid.shape == on_pde.grid.shape and on_core.grid.axes_bounds == on_pde.grid.axes_bounds
    np.testing.assert_allclose(on_core.state.data, on_pde.state.data, rtol=1e-13, atol=1e-15)


def test_result_extras_and_summary_of_the_2d_cell():
    """The 2-D cell's Result fields from a py-pde case and from the native engine's case are the
    same numbers, and the summary is that of the measures."""
    from icidr_pde.case import build_case
    from icidr_pde.cells.plane2d.core import measures
    from icidr_pde.native_case import Plane2DCase

    plane = get_cell("plane2d")
    case = build_case("icidr", "bump2d", "fv2d", (6, 5))
    data = np.stack([case.state.data, case.state.data * 1.01])
    extras = plane.result_extras(case, data)
    assert extras["Nx"] == 6 and extras["L"] == 30.0
    assert extras["measures"][0] == measures(case.pde, case.grid, case.scene, data[0])
    native = Plane2DCase("icidr", "bump2d", (6, 5))
    by_native = plane.result_extras(native, data)
    assert by_native["Nx"] == 6 and by_native["L"] == 30.0
    for a, b in zip(by_native["measures"], extras["measures"]):
        assert a == pytest.approx(b, rel=1e-12)

    class R:
        discretization, N, time_labels = "fv2d", 5, ["0", "1"]
        Nx, L, measures = 6, 30.0, extras["measures"]

    summary = plane.result_summary(R)
    assert summary["Nx"] == 6 and summary["Nz"] == 5 and summary["L"] == 30.0
    assert summary["l2_velocity"] == {"0": extras["measures"][0]["l2_velocity"], "1": extras["measures"][1]["l2_velocity"]}
    assert cell_of_result(R) is plane
    R.discretization = "a custom class"
    assert cell_of_result(R) is plane
    R.measures = R.Nx = R.L = None
    assert cell_of_result(R) is get_cell("shear1d")
    assert get_cell("shear1d").result_summary(R) == {} and get_cell("shear1d").result_extras(case, data) == {}


def test_the_recorders_ask_the_cell_whether_it_draws_profiles():
    from icidr_pde.case import build_case
    from icidr_pde.recorders import make_recorders

    case = build_case("icidr", "bump2d", "fv2d", (6, 5))
    assert case.cell is get_cell("plane2d") and not case.cell.profiles and build_case("icidr", "shear").cell.profiles
    with pytest.raises(ValueError, match="`live_plot` and `movie` draw 1-D scenes"):
        make_recorders(case, 1.0, snap_times=[], live_plot=True)


def _cell(module):
    """The cell a module belongs to ('shear1d' for icidr_pde.cells.shear1d.fd), else None."""
    parts = module.split(".")
    return parts[2] if parts[:2] == ["icidr_pde", "cells"] and len(parts) > 2 and parts[2] in PACKAGES else None


def test_a_cell_never_imports_another_cell():
    """No module of a cell's folder imports (at module level or in a function) a module of
    another cell's, and no module below the cells (laws, the scheme registry and contract,
    the compiled problems' builder) imports a cell's module: what a cell imports never leads
    into another cell through the layers below it."""
    graph = import_graph()
    crossing = sorted((m, t) for m, targets in graph.items() if _cell(m) for t in targets
                      if _cell(t) and _cell(t) != _cell(m))
    assert crossing == []
    below = ("icidr_pde.rheology", "icidr_pde.discretizations", "icidr_pde.native", "icidr_pde.cells.base")
    into = sorted((m, t) for m, targets in graph.items() if m.startswith(below) for t in targets if _cell(t))
    assert into == []


def test_the_rule_finds_a_crossing():
    assert _cell("icidr_pde.cells.plane2d.core") == "plane2d" and _cell("icidr_pde.cells.base") is None
    assert _cell("icidr_pde.cells") is None and _cell("icidr_pde.native") is None


#: the modules that ask the cell instead of testing a dimension
ASK_THE_CELL = ("icidr_pde/result.py", "icidr_pde/snapshots.py", "icidr_pde/engines/stiff.py",
                "icidr_pde/discretizations/grid_size.py", "icidr_pde/native/build.py", "icidr_pde/engines/choose.py",
                "icidr_pde/api.py", "icidr_pde/recorders.py")


def _dimension_tests(source: str) -> list[str]:
    """Names and constants of `source` that test a dimension or name one cell: ``dim``, ``ndim``,
    a kinematics, a scheme or cell named in a string (docstrings aside)."""
    import ast

    tree = ast.parse(source)
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef)) and node.body
                  and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    named = {"dim", "ndim", "two_d", "PLANE_FLOW", "SHEAR_CELL"}
    cells_named = set(SCHEMES) | set(PACKAGES) | {"plane_flow", "shear_cell"}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in named or isinstance(node, ast.Attribute) and node.attr in named:
            found.append(getattr(node, "id", None) or node.attr)
        elif isinstance(node, ast.Constant) and id(node) not in docstrings and isinstance(node.value, str) \
                and (node.value in cells_named or "ICIDR_PLANE" in node.value):
            found.append(node.value)
    return found


@pytest.mark.parametrize("path", ASK_THE_CELL)
def test_these_modules_ask_the_cell(path):
    from .test_import_graph import ROOT

    assert _dimension_tests((ROOT / path).read_text()) == []


def test_the_dimension_test_finder_finds():
    found = _dimension_tests("x = pde.dim == 2\nif state.data.ndim > 2: pass\ny = name == 'fv2d'\n")
    assert sorted(found) == ["dim", "fv2d", "ndim"]
    assert _dimension_tests('"""A docstring naming fv2d."""\nimport os\n') == []


def test_the_driver_selects_no_cell():
    """cvode_driver.c and problem.h integrate any problem: no cell, scheme or kernel of one is named
    in them, and no #if chooses one; each cell's C is its folder's problem.c."""
    import re

    from .test_import_graph import ROOT

    native = ROOT / "icidr_pde" / "native"
    for name in ("cvode_driver.c", "problem.h"):
        text = (native / name).read_text()
        assert not re.search(r"ICIDR_PLANE|KIND_|\b(fd|cheb|fv2d|plane2d)_\w+\(", text), name
        for line in text.splitlines():
            if line.startswith("#if"):
                assert re.fullmatch(r"#ifdef ICIDR_BLAS", line), line  # a build's feature, not a cell
    for cell in cells().values():
        text = cell.problem_source()
        assert all(f"EXPORT Native *{name}(" in text or f" {name}(" in text for name in cell.c_functions)


def test_the_library_key_and_code_version_follow_the_c_sources(monkeypatch):
    """A change to a cell's problem.c changes its library's key (so the kernel cache builds it
    anew), and the kernel cache's code version reads every cell's C and templates."""
    import os

    from icidr_pde import kernel_cache
    from icidr_pde.cells.base import Cell
    from icidr_pde.native import build
    from icidr_pde.rheology import PLANE_FLOW, SHEAR_CELL, get_rheology

    args = (["libsundials_cvode.so"], "int", "gcc")
    for kinematics in (SHEAR_CELL, PLANE_FLOW):
        before = build._key(get_rheology("icidr"), kinematics, *args)
        assert cell_of(kinematics).problem_source() in build._driver(kinematics)
        original = Cell.problem_source
        monkeypatch.setattr(Cell, "problem_source", lambda self: original(self) + "\n/* changed */\n")
        assert build._key(get_rheology("icidr"), kinematics, *args) != before
        monkeypatch.undo()
    root = os.path.dirname(kernel_cache.__file__)
    folders = {sub for pattern in kernel_cache._VERSION_SOURCES for sub in kernel_cache._folders(root, pattern)}
    for cell in cells().values():
        assert f"cells/{cell.name}" in folders and f"cells/{cell.name}/templates" in folders
        assert cell.compiled_problem.endswith(kernel_cache._VERSION_SOURCES["cells/*"])


def test_each_library_has_its_cells_functions_only():
    from icidr_pde.native import NativeUnavailable, build
    from icidr_pde.rheology import PLANE_FLOW, SHEAR_CELL, get_rheology

    try:
        libraries = {k.name: build.library(get_rheology("icidr"), k) for k in (SHEAR_CELL, PLANE_FLOW)}
    except NativeUnavailable as err:
        pytest.skip(str(err))
    for name, lib in libraries.items():
        mine = cell_of(name).c_functions
        others = {f for cell in cells().values() if cell is not cell_of(name) for f in cell.c_functions}
        assert all(hasattr(lib, f) for f in list(mine) + list(build.DRIVER_FUNCTIONS))
        assert not any(hasattr(lib, f) for f in others)


def test_the_registry_keeps_its_order_whatever_was_imported_first():
    """The 2-D cell's descriptor imported first (by its py-pde adapter) leaves the registry's
    order, which is the order of the scenes (the first help text of a parameter wins)."""
    import os
    import subprocess
    import sys

    from .test_import_graph import ROOT

    code = ("import icidr_pde.cells.plane2d.pde\nfrom icidr_pde.cells import cells\nimport icidr_pde.scenes as s\n"
            "print(list(cells()), list(s.SCENES), s.scene_parameters()['eps'])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT,
                         env=dict(os.environ, PYTHONPATH=str(ROOT))).stdout
    assert out.split("] ")[0] + "]" == "['shear1d', 'plane2d']"
    assert "['shear', 'sine', 'bump2d', 'bump1d', 'mode2d']" in out and out.strip().endswith("(3.16)")
