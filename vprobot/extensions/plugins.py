"""Plugins: extensions (planners, rewards, stop rules, ...) in modules outside the package.

A plugin is a module that registers what it defines when it is imported (docs/extending.md).
`vprobot` imports, before it checks its arguments against the registries, the modules of the
`vprobot.plugins` entry points of the installed distributions (unless it is given no command:
`vprobot --help` lists the commands, which no plugin changes), then each `--plugin`: a module
name importable on `sys.path` (`mypkg.planners`), or a path to a `.py` file (`./mytop.py`).

A child process (a Ray worker, a `vprobot.compute.processes.worker_pool` worker, a `SubprocVecEnv`
env) is a fresh process that imports only what its function needs, so every function handed to
one is wrapped by `in_child`: it carries the list this process loaded (`loaded`), and the child
loads it before running the function. Passed with the function, it reaches a Ray started by
someone else or a cluster as surely as a local process, and loading again is a no-op. A vprobot
command run as a child (`report check`'s `evaluate`) gets the list as its `--plugin` options
(`command_options`).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import importlib.util
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import ParamSpec, TypeVar

ENTRY_POINT_GROUP = "vprobot.plugins"
"""The entry-point group whose modules every `vprobot` command imports."""

_P = ParamSpec("_P")
_R = TypeVar("_R")

_loaded: list[str] = []
"""What `load` imported in this process, in order: module names and absolute `.py` paths."""


def entry_point_modules() -> list[str]:
    """The modules of the `vprobot.plugins` entry points of the installed distributions."""
    # Reading the distributions' metadata costs about 50 ms, which `vprobot --help` skips.
    import importlib.metadata

    return [entry.module for entry in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)]


def global_options(argv: Sequence[str]) -> argparse.Namespace:
    """The `--plugin` values among the global options of `argv` (those before the command) and
    the rest (`command`: the command and its arguments); a malformed `--plugin` is left to the
    command line's parser to report."""
    parser = argparse.ArgumentParser(add_help=False, exit_on_error=False)
    parser.add_argument("--plugin", action="append", default=[])
    parser.add_argument("command", nargs=argparse.REMAINDER)
    try:
        return parser.parse_known_args(argv)[0]
    except argparse.ArgumentError:
        return argparse.Namespace(plugin=[], command=[])


def load_requested(argv: Sequence[str]) -> None:
    """Load the entry points' modules (when `argv` names a command), then the `--plugin` values
    of a command line's `argv`.

    Raises:
        ValueError: Naming the first plugin that fails to import and its error.
    """
    options = global_options(argv)
    names_a_command = any(not word.startswith("-") for word in options.command)
    load([*(entry_point_modules() if names_a_command else []), *options.plugin])


def load(plugins: Sequence[str]) -> None:
    """Import each plugin not yet loaded, in order: a module name, or a path to a `.py` file
    (imported as a module named after the file).

    Raises:
        ValueError: Naming the first plugin that fails to import and its error: whatever its
            code raised, `sys.exit` included, or a name it registers that is taken.
    """
    for plugin in plugins:
        key = str(Path(plugin).resolve()) if plugin.endswith(".py") else plugin
        if key in _loaded:
            continue
        try:
            _import(key)
        except (Exception, SystemExit) as error:  # whatever the plugin's code raised
            message = str(error).splitlines()[0] if str(error) else ""
            raise ValueError(f"plugin {plugin!r} failed to import: {type(error).__name__}"
                             f"{': ' if message else ''}{message}") from None
        _loaded.append(key)


def _import(key: str) -> None:
    """Import a module by name, or a `.py` file (an absolute path) as a module named after it."""
    if not key.endswith(".py"):
        importlib.import_module(key)
        return
    path = Path(key)
    if not path.is_file():
        raise FileNotFoundError(f"no such file: {path}")
    if path.stem in sys.modules:
        raise ValueError(f"a module named {path.stem!r} is already imported; rename the file")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    assert spec is not None and spec.loader is not None  # a .py file always has both
    module = importlib.util.module_from_spec(spec)
    # In sys.modules, so that its classes pickle and its dataclasses resolve their module.
    sys.modules[path.stem] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[path.stem]
        raise


def loaded() -> tuple[str, ...]:
    """What `load` imported in this process, in order, as `load` takes it in another process."""
    return tuple(_loaded)


def command_options() -> list[str]:
    """The global options that load, in a vprobot command run as a child, the plugins this
    process has loaded (`loaded`)."""
    return [option for plugin in _loaded for option in ("--plugin", plugin)]


def in_child(function: Callable[_P, _R]) -> Callable[_P, _R]:
    """`function`, for another process to call: there it first loads the plugins this process
    has loaded (`loaded`, taken now). Picklable when `function` is."""
    return functools.partial(_load_then, loaded(), function)


def _load_then(plugins: Sequence[str], function: Callable[_P, _R], /, *args: _P.args,
               **kwargs: _P.kwargs) -> _R:
    load(plugins)
    return function(*args, **kwargs)
