"""No circles among the module-level imports of icidr_pde and stability, and the layers of
docs/engines.md: studies and DEM know no command line, studies no interface (figures, movies,
plots); schemes and the run path know no study and no interface.

For circles, imports inside functions are lazy and are not edges; every module-level
``import``/``from ... import`` (including inside ``if``/``try`` at top level) is. For the
layers every import is an edge, lazy or not: a lazy import is still a dependency.
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


def top_level_imports(tree):
    """Import nodes not nested in a function or class body."""
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        elif isinstance(node, (ast.If, ast.Try)):
            stack.extend(node.body + node.orelse)
            stack.extend(getattr(node, "finalbody", []))
            for handler in getattr(node, "handlers", []):
                stack.extend(handler.body)


def import_graph(lazy=False):
    modules = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            modules[module_name(path)] = path
    graph = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        base = name.split(".") if is_package else name.split(".")[:-1]
        edges = set()
        tree = ast.parse(path.read_text())
        nodes = (
            [n for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
            if lazy
            else top_level_imports(tree)
        )
        for node in nodes:
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                prefix = base[: len(base) - node.level + 1] if node.level else []
                source = ".".join(prefix + ([node.module] if node.module else []))
                # `from package import module` needs the module; the package is already loaded
                targets = [f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source
                           for alias in node.names]
            for target in targets:
                # the module itself, or the package whose __init__ runs first
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target and target != name:
                    edges.add(target)
        graph[name] = edges
    return graph


def cycles(graph):
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for succ in graph[node]:
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


def is_cli(module):
    """A command line: ``*.cli``, ``*_cli``, ``__main__`` and the argparse types."""
    last = module.rpartition(".")[2]
    return last in ("cli", "__main__") or last.endswith("_cli") or module == "icidr_pde.argtypes"


def is_interface(module):
    """What faces a person: command lines, figures, movies, plots."""
    return is_cli(module) or under(module, "icidr_pde.figures", "icidr_pde.movies", "icidr_pde.plotting")


def is_study(module):
    return under(module, "icidr_pde.studies")


def is_scheme(module):
    return under(module, "icidr_pde.rheology", "icidr_pde.discretizations")


def is_run_path(module):
    return under(module, "icidr_pde.api", "icidr_pde.case", "icidr_pde.engines",
                 "icidr_pde.native", "icidr_pde.live_plot", "icidr_pde.result", "icidr_pde.validation")


def is_engine(module):
    return under(module, "icidr_pde.engines")


def is_screen_or_case(module):
    """What an engine must not know: schemes, cases, scenes, results, screens."""
    return (is_scheme(module) or is_study(module) or is_interface(module)
            or under(module, "icidr_pde.case", "icidr_pde.scenes", "icidr_pde.scenes2d", "icidr_pde.scene_base",
                     "icidr_pde.live_plot", "icidr_pde.progress", "icidr_pde.result", "icidr_pde.api"))


RULES = {
    "an engine imports a scheme, a case, a scene or a screen": (is_engine, is_screen_or_case),
    # the DEM has a command of its own (dem.cli, dem.__main__); studies/ holds none
    "a study or DEM module imports a command line": (
        lambda m: is_study(m) or (under(m, "icidr_pde.dem") and not is_cli(m)), is_cli),
    "a study imports an interface": (is_study, is_interface),
    "a scheme imports a study or an interface": (is_scheme, lambda t: is_study(t) or is_interface(t)),
    "the run path imports a study or an interface": (is_run_path, lambda t: is_study(t) or is_interface(t)),
}
#: the edges left: ``run(movie=...)`` adds the recorder of the movie frames, rendered at the end;
#: py-pde's solver adapter refuses a grid too large for memory by the schemes' size model;
#: ``Result.plot()`` draws the Result with the figure of ``run --plot`` (imported when called)
KNOWN = {("icidr_pde.api", "icidr_pde.movies.frames"),
         ("icidr_pde.engines.stiff", "icidr_pde.discretizations.grid_size"),
         ("icidr_pde.result", "icidr_pde.plotting")}


def layer_violations(graph, known=frozenset()):
    """{rule: sorted [(module, target)]} of the edges that break a rule of :data:`RULES`."""
    found = {}
    for rule, (source, target) in RULES.items():
        edges = sorted((m, t) for m in graph if source(m) for t in graph[m]
                       if target(t) and (m, t) not in known)
        if edges:
            found[rule] = edges
    return found


def test_the_graph_sees_known_edges():
    graph = import_graph()
    assert "icidr_pde.rheology" in graph
    assert any(target.startswith("icidr_pde") for target in graph["icidr_pde.api"])


def test_a_circle_is_found():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_circles():
    assert cycles(import_graph()) == []


def test_a_study_importing_the_command_line_is_found():
    graph = {"icidr_pde.studies.sim2d": {"icidr_pde.cli"}, "icidr_pde.dem.fit": {"icidr_pde.argtypes"},
             "icidr_pde.studies.__main__": {"icidr_pde.cli"},
             "icidr_pde.dem.cli": {"icidr_pde.argtypes"}, "icidr_pde.discretizations.fd": {"icidr_pde.studies"},
             "icidr_pde.api": {"icidr_pde.plotting", "icidr_pde.scenes"},
             "icidr_pde.engines.scipy": {"icidr_pde.validation", "icidr_pde.discretizations.fd"}}
    assert layer_violations(graph) == {
        "an engine imports a scheme, a case, a scene or a screen": [("icidr_pde.engines.scipy",
                                                                     "icidr_pde.discretizations.fd")],
        "a study or DEM module imports a command line": [("icidr_pde.dem.fit", "icidr_pde.argtypes"),
                                                          ("icidr_pde.studies.__main__", "icidr_pde.cli"),
                                                          ("icidr_pde.studies.sim2d", "icidr_pde.cli")],
        "a study imports an interface": [("icidr_pde.studies.__main__", "icidr_pde.cli"),
                                         ("icidr_pde.studies.sim2d", "icidr_pde.cli")],
        "a scheme imports a study or an interface": [("icidr_pde.discretizations.fd", "icidr_pde.studies")],
        "the run path imports a study or an interface": [("icidr_pde.api", "icidr_pde.plotting")]}


def test_the_layers_are_kept():
    assert layer_violations(import_graph(lazy=True), KNOWN) == {}


if __name__ == "__main__":  # list the circles that lazy imports (inside functions) close as well, and the layers
    graph, eager = import_graph(lazy=True), import_graph()
    for component in cycles(graph):
        for module in component:
            for target in sorted(graph[module] & set(component)):
                print(module, "->", target, "" if target in eager[module] else "(lazy)")
        print()
    for rule, edges in layer_violations(graph).items():
        print(f"{rule}:")
        for module, target in edges:
            print(f"  {module} -> {target}{'' if target in eager[module] else ' (lazy)'}"
                  f"{' (known)' if (module, target) in KNOWN else ''}")
