"""The layers of docs/architecture.md, as a test: no import circle among the modules of
icidr_pde and stability, and no edge that breaks a rule of :data:`RULES`.

Every import is an edge, at module level or inside a function: a lazy import keeps start-up
cheap, it is still a dependency, and a circle it closes is still a circle. A look-up of one of
the package's modules in ``sys.modules`` is an edge too (it depends on what that module did).
An import under ``if TYPE_CHECKING:`` is not: it is never run, it names a type for annotations.
``python tests/test_import_graph.py`` lists the circles and the broken rules.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("icidr_pde", "stability")


def module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _type_checking(node) -> bool:
    """``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``): a block only a type checker runs."""
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and (
        (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
        or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"))


def all_imports(tree):
    """Import nodes anywhere, those of ``if TYPE_CHECKING:`` blocks excepted."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        if _type_checking(node):
            stack.extend(node.orelse)
            continue
        stack.extend(ast.iter_child_nodes(node))


def top_level_imports(tree):
    """Import nodes not nested in a function or class body (nor in ``if TYPE_CHECKING:``)."""
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif _type_checking(node):
            stack.extend(node.orelse)
        elif isinstance(node, (ast.If, ast.Try)):
            stack.extend(node.body + node.orelse)
            stack.extend(getattr(node, "finalbody", []))
            for handler in getattr(node, "handlers", []):
                stack.extend(handler.body)


def _is_sys_modules(node) -> bool:
    return (isinstance(node, ast.Attribute) and node.attr == "modules"
            and isinstance(node.value, ast.Name) and node.value.id == "sys")


def looked_up(tree):
    """Module names looked up in ``sys.modules``: ``sys.modules.get(name)``, ``sys.modules[name]``,
    ``name in sys.modules``."""
    for name, _ in looked_up_at(tree):
        yield name


def looked_up_at(tree):
    """(module name, line) of each look-up of :func:`looked_up`."""
    for node in ast.walk(tree):
        key = None
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and _is_sys_modules(node.func.value)
                and node.args):
            key = node.args[0]
        elif isinstance(node, ast.Subscript) and _is_sys_modules(node.value):
            key = node.slice
        elif (isinstance(node, ast.Compare) and len(node.comparators) == 1
              and _is_sys_modules(node.comparators[0])):
            key = node.left
        if isinstance(key, ast.Constant) and isinstance(key.value, str):
            yield key.value, node.lineno


#: modules outside the packages whose importers a rule names
WATCHED = ("argparse",)


def package_modules():
    """{module name: path} of every module of :data:`PACKAGES`."""
    return {module_name(path): path for package in PACKAGES for path in (ROOT / package).rglob("*.py")}


def module_edges(name, path, modules, lazy=True):
    """(target, line) of each import of the module `name` at `path` (see :func:`import_graph`)."""
    is_package = path.name == "__init__.py"
    base = name.split(".") if is_package else name.split(".")[:-1]
    tree = ast.parse(path.read_text())
    nodes = list(all_imports(tree)) if lazy else top_level_imports(tree)
    targets = list(looked_up_at(tree)) if lazy else []
    for node in nodes:
        if isinstance(node, ast.Import):
            targets += [(alias.name, node.lineno) for alias in node.names]
        else:
            prefix = base[: len(base) - node.level + 1] if node.level else []
            source = ".".join(prefix + ([node.module] if node.module else []))
            # `from package import module` needs the module; the package is already loaded
            targets += [(f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source, node.lineno)
                        for alias in node.names]
    for target, line in targets:
        if target.partition(".")[0] in WATCHED:
            yield target.partition(".")[0], line
            continue
        # the module itself, or the package whose __init__ runs first
        while target and target not in modules:
            target = target.rpartition(".")[0]
        if target and target != name:
            yield target, line


def import_graph(lazy=True):
    """{module: modules it imports}: every import (`lazy`, the default) or only the module-level
    ones; with `lazy`, the modules looked up in ``sys.modules`` as well. Of the modules outside the
    packages only :data:`WATCHED` appear."""
    modules = package_modules()
    return {name: {target for target, _ in module_edges(name, path, modules, lazy)} for name, path in modules.items()}


def import_sites(module, target):
    """``path:line`` of each import (or ``sys.modules`` look-up) in `module` that is an edge to `target`."""
    modules = package_modules()
    path = modules[module]
    return [f"{path.relative_to(ROOT)}:{line}" for found, line in module_edges(module, path, modules) if found == target]


def private_imports():
    """[(module, source, name)]: names with a leading underscore imported from a module of another
    of :data:`PACKAGES` (a private name is its own package's business)."""
    found = []
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            name = module_name(path)
            base = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
            for node in ast.walk(ast.parse(path.read_text())):
                if not isinstance(node, ast.ImportFrom):
                    continue
                prefix = base[: len(base) - node.level + 1] if node.level else []
                source = ".".join(prefix + ([node.module] if node.module else []))
                if source.partition(".")[0] in PACKAGES and source.partition(".")[0] != package:
                    found += [(name, source, a.name) for a in node.names
                              if a.name.startswith("_") and not a.name.startswith("__")]
    return sorted(found)


def cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for succ in graph[node] & graph.keys():  # WATCHED modules are ends, not nodes
            if succ not in index:
                visit(succ)
                low[node] = min(low[node], low[succ])
            elif succ in on_stack:
                low[node] = min(low[node], index[succ])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def under(module, *packages):
    return any(module == p or module.startswith(p + ".") for p in packages)


#: what a run records or shows besides its Result, each a recorder of the drive loop: the run path
#: reaches an interface through these only
RECORDERS = frozenset({"icidr_pde.snapshots", "icidr_pde.movies.frames", "icidr_pde.live_plot"})


#: the command line: every subcommand of ``icidr-pde``, the argparse types and pieces they share
COMMAND_LINE = "icidr_pde.cli"


def is_cli(module):
    return under(module, COMMAND_LINE)


def is_interface(module):
    """What faces a person: command lines, figures, movies (and the ffmpeg they run), plots, the live figure."""
    return is_cli(module) or under(module, "icidr_pde.figures", "icidr_pde.movies", "icidr_pde.plotting",
                                   "icidr_pde.live_plot", "icidr_pde.ffmpeg")


def is_study(module):
    return under(module, "icidr_pde.studies")


def is_dem(module):
    return under(module, "icidr_pde.dem")


def is_scheme(module):
    """Laws, schemes and cells."""
    return under(module, "icidr_pde.rheology", "icidr_pde.discretizations", "icidr_pde.cells")


def is_compiled_problem(module):
    return under(module, "icidr_pde.native")


def is_run_path(module):
    return under(module, "icidr_pde.api", "icidr_pde.case", "icidr_pde.engines", "icidr_pde.native",
                 "icidr_pde.result", "icidr_pde.validation", "icidr_pde.times", "icidr_pde.presets",
                 "icidr_pde.outputs", "icidr_pde.snapshots", "icidr_pde.progress", "icidr_pde.schedule",
                 "icidr_pde.drive", "icidr_pde.recorders", "icidr_pde.native_case")


def is_engine(module):
    return under(module, "icidr_pde.engines")


def is_case(module):
    """What builds a case: the case and its scenes."""
    return under(module, "icidr_pde.case", "icidr_pde.native_case", "icidr_pde.scenes", "icidr_pde.scene_base")


def is_case_or_screen(module):
    """What an engine must not know: schemes, the DEM, studies, cases, scenes, the run's schedule
    and Result, screens."""
    return (is_scheme(module) or is_dem(module) or is_study(module) or is_interface(module)
            or under(module, "icidr_pde.case", "icidr_pde.scenes", "icidr_pde.scene_base",
                     "icidr_pde.times", "icidr_pde.presets", "icidr_pde.progress", "icidr_pde.result",
                     "icidr_pde.snapshots", "icidr_pde.api", "icidr_pde.schedule", "icidr_pde.drive",
                     "icidr_pde.recorders"))


RULES = {
    "an engine imports or looks up a scheme, the DEM, a study, a case, a scene or a screen": (
        is_engine, is_case_or_screen),
    # a compiled problem is a scheme's (it imports laws and schemes) but an engine integrates it
    "a compiled problem imports or looks up the DEM, a study, a case, a scene or a screen": (
        is_compiled_problem, lambda t: is_dem(t) or is_study(t) or is_case(t) or is_interface(t)),
    "a scheme or cell imports an engine, a study or an interface": (
        is_scheme, lambda t: is_engine(t) or is_study(t) or is_interface(t)),
    "a compiled problem imports an engine": (is_compiled_problem, is_engine),
    "a study or DEM module imports a command line": (lambda m: is_study(m) or is_dem(m), is_cli),
    "a study imports an interface": (is_study, is_interface),
    "the run path imports a study, or an interface other than a recorder": (
        is_run_path, lambda t: is_study(t) or (is_interface(t) and t not in RECORDERS)),
}
#: the edges that break a rule today, each with what must change for it to go: the list only
#: shrinks (:func:`test_every_known_offender_still_offends` fails on an edge that has gone)
KNOWN = {
    ("icidr_pde.result", "icidr_pde.plotting"):
        "Result.plot() draws a finished run with the figure of run --plot, imported when it is "
        "called (no run calls it, a run loads no figure); kept",
}


def layer_violations(graph, known=frozenset()):
    """{rule: sorted [(module, target)]} of the edges that break a rule of :data:`RULES`."""
    found = {}
    for rule, (source, target) in RULES.items():
        edges = sorted((m, t) for m in graph if source(m) for t in graph[m]
                       if target(t) and (m, t) not in known)
        if edges:
            found[rule] = edges
    return found


def check_rule(rule):
    """Fail with every edge that breaks `rule`, each named with where it is."""
    graph, eager = import_graph(), import_graph(lazy=False)
    broken = layer_violations(graph, KNOWN).get(rule, [])
    assert not broken, f"{rule}:\n" + "\n".join(
        f"  {m} -> {t}{'' if t in eager[m] else ' (lazy or look-up)'} at {', '.join(import_sites(m, t)) or '?'}"
        for m, t in broken)


def test_the_graph_sees_known_edges():
    graph = import_graph(lazy=False)
    assert "icidr_pde.rheology" in graph
    assert any(target.startswith("icidr_pde") for target in graph["icidr_pde.api"])
    assert "argparse" in graph["icidr_pde.cli.common"]


def test_an_edge_is_named_with_its_file_and_line():
    lines = Path(ROOT / "icidr_pde/engines/petsc.py").read_text().splitlines()
    sites = import_sites("icidr_pde.engines.petsc", "icidr_pde.loaded_mpi")
    assert sites and all(site.startswith("icidr_pde/engines/petsc.py:") for site in sites)
    assert all("loaded_mpi" in lines[int(site.rpartition(":")[2]) - 1] for site in sites)


def test_lazy_imports_and_sys_modules_look_ups_are_edges(tmp_path):
    tree = ast.parse("import sys\n"
                     "def f():\n    from .b import c\n    return sys.modules.get('icidr_pde.dem._lammps')\n"
                     "x = sys.modules['icidr_pde.api'] if 'icidr_pde.case' in sys.modules else None\n")
    assert set(looked_up(tree)) == {"icidr_pde.dem._lammps", "icidr_pde.api", "icidr_pde.case"}
    assert not list(top_level_imports(tree))[1:]
    graph = import_graph()
    assert "icidr_pde.case" in graph["icidr_pde.api"] - import_graph(lazy=False)["icidr_pde.api"]


def test_type_checking_imports_are_not_edges():
    tree = ast.parse("from typing import TYPE_CHECKING\nimport typing\n"
                     "if TYPE_CHECKING:\n    from .a import A\nelse:\n    from .b import B\n"
                     "if typing.TYPE_CHECKING:\n    import c\n"
                     "def f():\n    if TYPE_CHECKING:\n        import d\n    import e\n")
    names = lambda nodes: sorted(getattr(n, "module", None) or n.names[0].name for n in nodes)  # noqa: E731
    assert names(all_imports(tree)) == ["b", "e", "typing", "typing"]
    assert names(top_level_imports(tree)) == ["b", "typing", "typing"]


def test_a_circle_is_found():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_circles_lazy_imports_included():
    assert cycles(import_graph()) == []


def argparse_outside_the_command_line(graph):
    """Sorted modules outside ``icidr_pde.cli`` that import argparse."""
    return sorted(m for m in graph if "argparse" in graph[m] and not is_cli(m))


def test_argparse_only_in_the_command_line_package():
    """Only ``icidr_pde/cli/`` parses a command line: no module elsewhere in icidr_pde/ or stability/
    imports argparse (at module level or in a function)."""
    assert argparse_outside_the_command_line({"icidr_pde.cli.run": {"argparse"}, "icidr_pde.validation": {"argparse"},
                                              "stability.cli": {"argparse"}}) == ["icidr_pde.validation", "stability.cli"]
    assert argparse_outside_the_command_line(import_graph()) == []


def test_every_command_line_is_in_the_command_line_package():
    """No ``python -m`` main and no module named cli, *_cli or __main__ outside ``icidr_pde/cli/``: every
    command is a subcommand of ``icidr-pde``."""
    found = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            name, last = module_name(path), path.stem
            if last in ("cli", "__main__") or last.endswith("_cli") or "__name__ == \"__main__\"" in path.read_text():
                found.add(name)
    assert {name for name in found if not is_cli(name)} == set()
    assert "icidr_pde.cli.__main__" in found


def test_each_rule_finds_its_break():
    graph = {"icidr_pde.studies.failure_time": {"icidr_pde.cli", "argparse"}, "icidr_pde.dem.fit": {"icidr_pde.cli.argtypes"},
             "icidr_pde.studies.sim2d": {"icidr_pde.cli.cluster", "argparse", "icidr_pde.figures.two_d"},
             "icidr_pde.cli.dem": {"icidr_pde.cli.argtypes", "argparse"}, "icidr_pde.discretizations.fd": {"icidr_pde.studies"},
             "icidr_pde.discretizations.base": {"icidr_pde.engines.stiff"},
             "icidr_pde.rheology.cidr": {"icidr_pde.rheology.base"},
             "icidr_pde.native.cheb": {"icidr_pde.engines.base", "icidr_pde.validation"},
             "icidr_pde.native.fv2d": {"icidr_pde.case", "icidr_pde.dem._lammps", "icidr_pde.rheology",
                                       "icidr_pde.discretizations.fd_core", "icidr_pde.figures.two_d"},
             "icidr_pde.cells.plane2d.core": {"icidr_pde.engines.sundae", "icidr_pde.rheology"},
             "icidr_pde.api": {"icidr_pde.plotting", "icidr_pde.scenes", "icidr_pde.movies.frames", "icidr_pde.live_plot"},
             "icidr_pde.validation": {"argparse"},
             "icidr_pde.engines.stiff": {"icidr_pde.times", "icidr_pde.discretizations.grid_size"},
             "icidr_pde.engines.petsc": {"icidr_pde.dem._lammps", "icidr_pde.validation"},
             "icidr_pde.engines.scipy": {"icidr_pde.validation", "icidr_pde.discretizations.fd"}}
    assert layer_violations(graph) == {
        "an engine imports or looks up a scheme, the DEM, a study, a case, a scene or a screen": [
            ("icidr_pde.engines.petsc", "icidr_pde.dem._lammps"),
            ("icidr_pde.engines.scipy", "icidr_pde.discretizations.fd"),
            ("icidr_pde.engines.stiff", "icidr_pde.discretizations.grid_size"),
            ("icidr_pde.engines.stiff", "icidr_pde.times")],
        "a compiled problem imports or looks up the DEM, a study, a case, a scene or a screen": [
            ("icidr_pde.native.fv2d", "icidr_pde.case"), ("icidr_pde.native.fv2d", "icidr_pde.dem._lammps"),
            ("icidr_pde.native.fv2d", "icidr_pde.figures.two_d")],
        "a scheme or cell imports an engine, a study or an interface": [
            ("icidr_pde.cells.plane2d.core", "icidr_pde.engines.sundae"),
            ("icidr_pde.discretizations.base", "icidr_pde.engines.stiff"),
            ("icidr_pde.discretizations.fd", "icidr_pde.studies")],
        "a compiled problem imports an engine": [("icidr_pde.native.cheb", "icidr_pde.engines.base")],
        "a study or DEM module imports a command line": [("icidr_pde.dem.fit", "icidr_pde.cli.argtypes"),
                                                          ("icidr_pde.studies.failure_time", "icidr_pde.cli"),
                                                          ("icidr_pde.studies.sim2d", "icidr_pde.cli.cluster")],
        "a study imports an interface": [("icidr_pde.studies.failure_time", "icidr_pde.cli"),
                                         ("icidr_pde.studies.sim2d", "icidr_pde.cli.cluster"),
                                         ("icidr_pde.studies.sim2d", "icidr_pde.figures.two_d")],
        "the run path imports a study, or an interface other than a recorder": [
            ("icidr_pde.api", "icidr_pde.plotting"), ("icidr_pde.native.fv2d", "icidr_pde.figures.two_d")]}


def test_an_engine_knows_no_scheme_dem_study_case_or_screen():
    check_rule("an engine imports or looks up a scheme, the DEM, a study, a case, a scene or a screen")


def test_a_compiled_problem_knows_no_dem_study_case_or_screen():
    check_rule("a compiled problem imports or looks up the DEM, a study, a case, a scene or a screen")


def test_a_scheme_or_cell_imports_no_engine_study_or_interface():
    check_rule("a scheme or cell imports an engine, a study or an interface")


def test_a_compiled_problem_imports_no_engine():
    check_rule("a compiled problem imports an engine")


def test_no_study_or_dem_module_imports_a_command_line():
    check_rule("a study or DEM module imports a command line")


def test_no_study_imports_an_interface():
    check_rule("a study imports an interface")


def test_the_run_path_reaches_an_interface_only_through_recorders():
    check_rule("the run path imports a study, or an interface other than a recorder")


def test_every_rule_has_its_test():
    tested = {node.args[0].value for node in ast.walk(ast.parse(Path(__file__).read_text()))
              if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "check_rule"
              and node.args and isinstance(node.args[0], ast.Constant)}
    assert tested == set(RULES)


def test_every_known_offender_still_offends():
    """A known edge that has gone (or no longer breaks a rule) leaves :data:`KNOWN`: the list only shrinks."""
    broken = {edge for edges in layer_violations(import_graph()).values() for edge in edges}
    gone = sorted(set(KNOWN) - broken)
    assert not gone, f"no longer an offending import, remove from KNOWN: {gone}"


def test_no_private_name_crosses_packages():
    assert private_imports() == []


if __name__ == "__main__":  # the circles (lazy imports included), the broken rules, the private names
    graph, eager = import_graph(), import_graph(lazy=False)
    for component in cycles(graph):
        for module in component:
            for target in sorted(graph[module] & set(component)):
                print(module, "->", target, "" if target in eager[module] else "(lazy)")
        print()
    for rule, edges in layer_violations(graph).items():
        print(f"{rule}:")
        for module, target in edges:
            print(f"  {module} -> {target}{'' if target in eager[module] else ' (lazy or look-up)'}"
                  f" at {', '.join(import_sites(module, target))}{' (known)' if (module, target) in KNOWN else ''}")
    for module, source, name in private_imports():
        print(f"private: {module} imports {source}.{name}")
    broken = bool(cycles(graph) or layer_violations(graph, KNOWN) or private_imports())
    print("broken" if broken else "no circle, no broken rule")
