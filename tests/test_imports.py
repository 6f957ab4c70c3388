"""vprobot's modules import each other without circles, at module top level and inside functions.

An import inside a function is allowed only where it keeps a heavy optional dependency (torch and
stable-baselines3, Ray, the offscreen renderer, the shape generators) out of a module that is
light to import, never to hide a circle; each such import says why in a comment above it. The
command line imports what a command runs when it runs (its module docstring says so).
"""

from __future__ import annotations

import ast
from pathlib import Path

import vprobot

ROOT = Path(vprobot.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in ROOT.rglob("*.py")}


def _import_nodes(name: str) -> list[tuple[ast.stmt, set[str], bool]]:
    """Each import statement of module `name` with the vprobot modules it imports and whether
    it is inside a function (lazy). Imports under TYPE_CHECKING never run and are left out.
    `from package import sub` counts as importing the submodule."""
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
                for statement in child.orelse:
                    visit(ast.Module(body=[statement], type_ignores=[]), lazy)
            elif isinstance(child, ast.Import | ast.ImportFrom):
                if imported := modules(child):
                    found.append((child, imported, lazy))
            else:
                visit(child, lazy or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef
                                                 | ast.Lambda))

    visit(ast.parse(path.read_text()), False)
    return found


def _imports(name: str, lazy: bool = False) -> set[str]:
    """The vprobot modules `name` imports when it is imported (with `lazy`, or may import
    later, inside its functions)."""
    return {module for _, imported, inside in _import_nodes(name) if lazy or not inside
            for module in imported}


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


def test_cycle_search_finds_a_hand_made_circle() -> None:
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_module_import_graph_has_no_cycle() -> None:
    graph = {name: _top_level_imports(name) for name in MODULES}
    # The graph is the real one: the package imports its planners at top level.
    assert "vprobot.planners.runner" in graph["vprobot.planners"]
    assert _cycle(graph) is None


def test_import_graph_with_the_imports_inside_functions_has_no_cycle() -> None:
    graph = {name: _imports(name, lazy=True) for name in MODULES}
    # The graph holds the lazy imports: the agent planner loads torch only when it plans.
    assert "vprobot.agents.trained" in graph["vprobot.planners.agent"]
    assert "vprobot.agents.trained" not in _top_level_imports("vprobot.planners.agent")
    assert _cycle(graph) is None


def _lazy_without_reason(name: str) -> list[int]:
    """Lines of the imports of vprobot modules inside functions of `name` that no comment
    explains: one on the import's line or on the line above the first of a run of imports."""
    lines = MODULES[name].read_text().splitlines()
    starts = set()
    for node in ast.walk(ast.parse("\n".join(lines))):
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
    missing = {name: lines for name in MODULES if name != "vprobot.cli"
               if (lines := _lazy_without_reason(name))}
    assert missing == {}
    assert "imports what a command runs when it runs" in " ".join(
        (ast.get_docstring(ast.parse(MODULES["vprobot.cli"].read_text())) or "").split())


def test_only_the_benchmark_command_imports_benchmarks() -> None:
    """`vprobot cell` and every library module work without `vprobot.benchmarks`."""
    for name, path in MODULES.items():
        if name.startswith("vprobot.benchmarks"):
            continue
        assert not any(module.startswith("vprobot.benchmarks")
                       for module in _top_level_imports(name)), name
        tree = ast.parse(path.read_text())
        functions = [node for node in ast.walk(tree)
                     if isinstance(node, ast.FunctionDef) and any(
                         isinstance(inner, ast.ImportFrom) and (inner.module or "").startswith(
                             "vprobot.benchmarks") for inner in ast.walk(node))]
        assert [function.name for function in functions] in ([], ["command_benchmark"]), name
