"""vprobot's modules import each other without circles at module top level."""

from __future__ import annotations

import ast
from pathlib import Path

import vprobot

ROOT = Path(vprobot.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(path): path for path in ROOT.rglob("*.py")}


def _top_level_imports(name: str) -> set[str]:
    """The vprobot modules `name` imports when it is imported (not inside functions, not under
    TYPE_CHECKING). `from package import sub` counts as importing the submodule."""
    path = MODULES[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()

    def visit(nodes: list[ast.stmt]) -> None:
        for node in nodes:
            if isinstance(node, ast.If) and "TYPE_CHECKING" not in ast.unparse(node.test):
                visit(node.body)
                visit(node.orelse)
            elif isinstance(node, ast.Try):
                visit(node.body)
                for handler in node.handlers:
                    visit(handler.body)
                visit(node.orelse)
                visit(node.finalbody)
            elif isinstance(node, ast.Import):
                found.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parts = package.split(".")[:len(package.split(".")) - node.level + 1]
                    base = ".".join([*parts, *([node.module] if node.module else [])])
                for alias in node.names:
                    submodule = f"{base}.{alias.name}"
                    found.add(submodule if submodule in MODULES else base)

    visit(ast.parse(path.read_text()).body)
    return {module for module in found if module in MODULES and module != name}


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
