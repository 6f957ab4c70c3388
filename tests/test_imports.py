"""vprobot's modules import each other without circles, at module top level and inside functions.

The graph is that of what importing a module executes. Importing `a.b.c` executes the package
`a` (its `__init__`), then `a.b`, then `a.b.c`, each unless already started. So a module X that
imports `a.b.c` has an edge to each of them, except to the packages enclosing X: Python starts
a module's packages before the module, so X importing a sibling or a cousin runs no package
again. `from P import name` where `name` is no submodule reads P's own namespace, so it is an edge
to P even from inside P. An edge from a package to the submodules its `__init__` imports is an
ordinary edge: the pair is a circle only when the submodule leads back to the package, either by
reading its namespace or through a module outside the package that imports anything of it (and so
runs its `__init__`).

A cycle in that graph is a circle: whichever module on it is imported first, the imports lead
back to a module of the cycle that is still half-initialized, and which one that is (and so
what fails) depends on which module was imported first.

An import inside a function is allowed only where it keeps a heavy optional dependency (torch and
stable-baselines3, Ray, the offscreen renderer, the shape generators) out of a module that is
light to import, never to hide a circle: the graph with those imports has no cycle either, and
each such import says why in a comment above it. The command line (`vprobot.cli` and its
modules) imports what a command runs when it runs (its package docstring says so).

The modules sit in layers (`LAYERS`, drawn in docs/layers.md), and no import, at top level or
inside a function, executes a module of a higher layer than the importer's.
"""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import vprobot

ROOT = Path(vprobot.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in ROOT.rglob("*.py")}


@functools.cache
def _tree(name: str) -> ast.Module:
    """Module `name`'s syntax tree, parsed once per test process (read only)."""
    return ast.parse(MODULES[name].read_text())


@functools.cache
def _import_nodes(name: str, typing: bool = False) -> list[tuple[ast.stmt, set[str], bool]]:
    """Each import statement of module `name` with the vprobot modules it imports and whether
    it is inside a function (lazy). Imports under TYPE_CHECKING never run and are left out,
    unless `typing` (then they count as top-level ones). `from package import sub` counts as
    importing the submodule. Found once per test process (the callers only read it)."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: list[tuple[ast.stmt, set[str], bool]] = []

    def modules(node: ast.Import | ast.ImportFrom) -> set[str]:
        if isinstance(node, ast.Import):
            named = {alias.name for alias in node.names}
        else:
            base = node.module or ""
            if node.level:
                parts = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, *([node.module] if node.module else [])])
            named = {f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                     for alias in node.names}
        return {module for module in named if module in MODULES and module != name}

    def visit(node: ast.AST, lazy: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                for statement in [*child.orelse, *(child.body if typing else [])]:
                    visit(ast.Module(body=[statement], type_ignores=[]), lazy)
            elif isinstance(child, ast.Import | ast.ImportFrom):
                if imported := modules(child):
                    found.append((child, imported, lazy))
            else:
                visit(child, lazy or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef
                                                 | ast.Lambda))

    visit(_tree(name), False)
    return found


def _imports(name: str, lazy: bool = False, typing: bool = False) -> set[str]:
    """The vprobot modules `name` imports when it is imported (with `lazy`, or may import
    later, inside its functions; with `typing`, or names for its type hints only), as its
    import statements name them."""
    return {module for _, imported, inside in _import_nodes(name, typing)
            if lazy or not inside for module in imported}


def _enclosing(name: str) -> set[str]:
    """The packages whose `__init__` Python executes before module `name`."""
    parts = name.split(".")
    return {".".join(parts[:end]) for end in range(1, len(parts))}


def _executed(importer: str, imported: str) -> set[str]:
    """What an import of `imported` in module `importer` executes (see the module docstring):
    `imported` and its packages, less `importer` and the packages enclosing it, which started
    first. A package that encloses `importer` stays when it is what is imported (its
    namespace is read)."""
    return ({imported} | _enclosing(imported) - _enclosing(importer)) - {importer}


def _execution_graph(imports: dict[str, set[str]]) -> dict[str, set[str]]:
    """For each module, what its imports (the modules they name, by module) execute."""
    return {name: {executed for imported in named for executed in _executed(name, imported)}
            for name, named in imports.items()}


def _graph(lazy: bool, typing: bool = False) -> dict[str, set[str]]:
    """vprobot's execution graph (with `lazy`, the imports inside functions execute too; with
    `typing`, those for type hints only)."""
    return _execution_graph({name: _imports(name, lazy, typing) for name in MODULES})


def _top_level_imports(name: str) -> set[str]:
    return _imports(name)


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph as a path of modules, or None (depth-first search)."""
    state: dict[str, int] = {}
    trail: list[str] = []

    def walk(module: str) -> list[str] | None:
        state[module] = 1
        trail.append(module)
        for target in sorted(graph[module]):
            if state.get(target) == 1:
                return [*trail[trail.index(target):], target]
            if target not in state and (cycle := walk(target)) is not None:
                return cycle
        state[module] = 2
        trail.pop()
        return None

    for module in sorted(graph):
        if module not in state and (cycle := walk(module)) is not None:
            return cycle
    return None


LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("foundations", ("vprobot", "vprobot.files", "vprobot.compute", "vprobot.extensions",
                     "vprobot.geometry", "vprobot.sensing", "vprobot.rewards")),
    ("objects", ("vprobot.families", "vprobot.motors", "vprobot.parts")),
    ("configuration", ("vprobot.config", "vprobot.robots")),
    ("cell", ("vprobot.cell", "vprobot.kinematics", "vprobot.coverage")),
    ("episode", ("vprobot.episode",)),
    ("files in and out", ("vprobot.plan", "vprobot.export", "vprobot.render",
                          "vprobot.importers")),
    ("what planners use", ("vprobot.env", "vprobot.agents", "vprobot.stopping")),
    ("planners", ("vprobot.planners",)),
    ("evaluation", ("vprobot.evaluation",)),
    ("training and studies", ("vprobot.stop_studies", "vprobot.report", "vprobot.training")),
    ("benchmarks", ("vprobot.benchmarks",)),
    ("command line", ("vprobot.cli",)),
)
"""vprobot's layers, low to high, each a name and the top-level packages (and modules) it
holds: a module is in the layer of its top-level package, so a package sits whole in one
layer."""


def _prefix(module: str, layers: tuple[tuple[str, tuple[str, ...]], ...] = LAYERS) -> str:
    """The longest prefix of `layers` that is `module` or a package enclosing it."""
    return max((prefix for _, prefixes in layers for prefix in prefixes
                if module == prefix or module.startswith(prefix + ".")), key=len)


def _layer(module: str, layers: tuple[tuple[str, tuple[str, ...]], ...] = LAYERS) -> int:
    """The index of `module`'s layer in `layers`, low to high."""
    prefix = _prefix(module, layers)
    return next(index for index, (_, prefixes) in enumerate(layers) if prefix in prefixes)


def _upward(graph: dict[str, set[str]], layers: tuple[tuple[str, tuple[str, ...]], ...] = LAYERS
            ) -> list[str]:
    """Each edge of `graph` that executes a module of a higher layer than its importer's."""
    return [f"{module} ({layers[_layer(module, layers)][0]}) -> {target} "
            f"({layers[_layer(target, layers)][0]})"
            for module, targets in sorted(graph.items()) for target in sorted(targets)
            if _layer(target, layers) > _layer(module, layers)]


def test_cycle_search_finds_a_hand_made_circle() -> None:
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_an_import_executes_the_packages_not_yet_started() -> None:
    # From another package: the package, then the module (`vprobot` has started).
    assert _executed("vprobot.env.grid_state", "vprobot.planners.candidates") == {
        "vprobot.planners", "vprobot.planners.candidates"}
    # A sibling: the package has started.
    assert _executed("vprobot.planners.bscp", "vprobot.planners.candidates") == {
        "vprobot.planners.candidates"}
    # A cousin: the common packages have started, the cousin's own has not.
    assert _executed("vprobot.stopping.rules.grid", "vprobot.stopping.features") == {
        "vprobot.stopping.features"}
    assert _executed("vprobot.stopping.estimator", "vprobot.stopping.rules.grid") == {
        "vprobot.stopping.rules", "vprobot.stopping.rules.grid"}
    # The enclosing package's namespace, and a package's own submodule.
    assert _executed("vprobot.planners.runner", "vprobot.planners") == {"vprobot.planners"}
    assert _executed("vprobot.planners", "vprobot.planners.runner") == {
        "vprobot.planners.runner"}


def test_a_package_and_its_submodules_form_a_circle_only_through_the_package() -> None:
    # The package imports its modules, which import each other: no circle.
    assert _cycle(_execution_graph({"p": {"p.m", "p.n"}, "p.m": {"p.n"}, "p.n": set(),
                                    "x": {"p.m"}})) is None
    # A module of the package reads the package's namespace.
    assert _cycle(_execution_graph({"p": {"p.m"}, "p.m": {"p"}})) == ["p", "p.m", "p"]
    # A module of the package imports one outside that imports any module of the package.
    assert _cycle(_execution_graph({"p": {"p.m"}, "p.m": {"x"}, "p.n": set(),
                                    "x": {"p.n"}})) == ["p", "p.m", "x", "p"]


def test_module_import_graph_has_no_cycle() -> None:
    graph = _graph(lazy=False)
    # The graph is the real one: importing the episode's records from the env runs the
    # episode package, and a package runs the submodules its __init__ imports.
    assert "vprobot.episode" in graph["vprobot.env.observations"]
    assert "vprobot.episode.engine" in graph["vprobot.episode"]
    assert (cycle := _cycle(graph)) is None, " -> ".join(cycle)


def test_import_graph_with_the_imports_inside_functions_has_no_cycle() -> None:
    graph = _graph(lazy=True)
    # The graph holds the lazy imports: the agent planner loads torch only when it plans.
    assert "vprobot.agents.trained" in graph["vprobot.planners.agent"]
    assert "vprobot.agents.trained" not in _graph(lazy=False)["vprobot.planners.agent"]
    assert (cycle := _cycle(graph)) is None, " -> ".join(cycle)


def test_import_graph_with_the_type_only_imports_has_no_cycle() -> None:
    """A module that names another's class only in its hints still may not need it in a
    circle: the two would not be separable, and an import moved out of TYPE_CHECKING (to check
    an instance, say) would close it."""
    graph = _graph(lazy=True, typing=True)
    # The graph holds the type-only imports: the env names the cell's type in its hints only.
    assert "vprobot.cell.scene" in graph["vprobot.env.inspect_env"]
    assert "vprobot.cell.scene" not in _graph(lazy=True)["vprobot.env.inspect_env"]
    assert (cycle := _cycle(graph)) is None, " -> ".join(cycle)


def test_layer_check_catches_a_hand_made_upward_import() -> None:
    layers = (("low", ("p",)), ("high", ("q", "p.up")))
    graph = {"p": set(), "p.m": {"q"}, "p.up": {"q"}, "q": {"p.m"}}
    # `p.m` sits with its package below `q`; `p.up` sits apart from it, in `q`'s layer.
    assert _upward(graph, layers) == ["p.m (low) -> q (high)"]
    assert _upward({**graph, "p.m": set()}, layers) == []


def test_every_module_sits_in_a_declared_layer() -> None:
    # The root package is the lowest prefix: a new top-level module or package says where it
    # sits instead of falling to the bottom, and every prefix is a module of the package.
    assert [name for name in MODULES if name != "vprobot" and _prefix(name) == "vprobot"] == []
    assert [prefix for _, prefixes in LAYERS for prefix in prefixes
            if prefix not in MODULES] == []
    # The layers name top-level packages and modules only: no module sits apart from its
    # package.
    assert [prefix for _, prefixes in LAYERS for prefix in prefixes
            if prefix.count(".") > 1] == []


def test_no_import_points_up_a_layer() -> None:
    graph = _graph(lazy=True)
    # The check covers the imports inside functions: the agent planner loads the trained agent
    # when it plans, from a layer below the planners.
    assert "vprobot.agents.trained" in graph["vprobot.planners.agent"]
    assert _layer("vprobot.agents.trained") < _layer("vprobot.planners.agent")
    assert _upward(graph) == []


def _drawn_layers(page: str) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """The layers docs/layers.md draws in its `text` block (highest first; a line that starts
    blank goes on with the layer above it), low to high as `LAYERS` holds them."""
    drawn: list[tuple[str, list[str]]] = []
    for line in page.split("```text\n", 1)[1].split("\n```", 1)[0].splitlines():
        if line.startswith(" "):
            drawn[-1][1].extend(line.split())
        else:
            name, modules = re.split(r"\s{2,}", line, maxsplit=1)
            drawn.append((name, modules.split()))
    return tuple((name, tuple(module if module == "vprobot" else f"vprobot.{module}"
                              for module in modules)) for name, modules in reversed(drawn))


def test_the_docs_draw_the_declared_layers() -> None:
    page = (ROOT.parent / "docs" / "layers.md").read_text()
    assert _drawn_layers(page) == LAYERS


def _lazy_without_reason(name: str) -> list[int]:
    """Lines of the imports of vprobot modules inside functions of `name` that no comment
    explains: one on the import's line or on the line above the first of a run of imports."""
    lines = MODULES[name].read_text().splitlines()
    starts = set()
    for node in ast.walk(_tree(name)):
        for field in ("body", "orelse", "finalbody"):
            statements = getattr(node, field, None)
            if isinstance(statements, list):
                starts.update(statement.lineno for index, statement in enumerate(statements)
                              if isinstance(statement, ast.Import | ast.ImportFrom) and not (
                                  index and isinstance(statements[index - 1],
                                                       ast.Import | ast.ImportFrom)))
    missing = []
    for node, _, inside in _import_nodes(name):
        if not inside or "#" in lines[node.lineno - 1]:
            continue
        first = max(start for start in starts if start <= node.lineno)
        if not lines[first - 2].strip().startswith("#"):
            missing.append(node.lineno)
    return missing


def test_every_import_inside_a_function_says_why_it_is_lazy() -> None:
    missing = {name: lines for name in MODULES if name.split(".")[:2] != ["vprobot", "cli"]
               if (lines := _lazy_without_reason(name))}
    assert missing == {}
    assert "imports what a command runs when it runs" in " ".join(
        (ast.get_docstring(ast.parse(MODULES["vprobot.cli"].read_text())) or "").split())


def test_only_the_benchmark_command_imports_benchmarks() -> None:
    """`vprobot cell` and every library module work without `vprobot.benchmarks`."""
    for name in MODULES:
        if name.startswith("vprobot.benchmarks"):
            continue
        assert not any(module.startswith("vprobot.benchmarks")
                       for module in _top_level_imports(name)), name
        functions = [node for node in ast.walk(_tree(name))
                     if isinstance(node, ast.FunctionDef) and any(
                         isinstance(inner, ast.ImportFrom) and (inner.module or "").startswith(
                             "vprobot.benchmarks") for inner in ast.walk(node))]
        assert [function.name for function in functions] in ([], ["command_benchmark"]), name
