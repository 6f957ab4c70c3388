"""Named registries of the extension points (planners, rewards, encoders, part families, stop
rules, sensing models, export formats): a new one is a module that registers itself, and the
config, the CLI and the error messages read the names from the registry (docs/extending.md).

A registry knows the package of its bundled entries and imports every module of it the first
time it is read, so that a bundled extension is one file in that package; one from outside is a
plugin (`vprobot.plugins`), registered by being imported.
"""

from __future__ import annotations

import contextlib
import importlib
import pkgutil
import re
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Generic, Protocol, TypeVar, overload

T = TypeVar("T")
V = TypeVar("V")


class _Named(Protocol):
    """What `Registry.register_named` registers: anything with a name (a class's `name`)."""

    @property
    def name(self) -> str: ...


N = TypeVar("N", bound=_Named)


_REGISTRIES: list[Registry[Any]] = []
"""Every registry made, for `bundled_entries_first`."""


class UnknownNameError(KeyError, ValueError):
    """A name no entry of a registry has: a user error (ValueError) and a failed lookup
    (KeyError, so that the registry behaves as a mapping)."""

    def __str__(self) -> str:
        # KeyError would quote the message as a key.
        return str(self.args[0])


def _natural(name: str) -> list[tuple[int, str | int]]:
    """Sort key of a name in natural order: `R2` before `R10`."""
    return [(1, int(part)) if part.isdigit() else (0, part)
            for part in re.split(r"(\d+)", name) if part]


class Registry(Mapping[str, T], Generic[T]):
    """Entries of one kind by name, in natural name order (`R2` before `R10`), so that what a
    message lists does not depend on which module happened to be imported first.

    Args:
        kind: What an entry is, as error messages name it (`planner`, `reward`).
        package: The package whose modules register the bundled entries: the first read of the
            registry (a lookup, `in`, iteration, `len`) imports each of its modules whose name
            does not start with `_`, in name order. None: entries come only from `register`.

    Example:
        >>> GREETINGS: Registry[str] = Registry("greeting")
        >>> GREETINGS.register("shout", "HEY")
        'HEY'
        >>> @GREETINGS.register("hello")
        ... def hello() -> str:
        ...     return "Hello!"
        >>> list(GREETINGS)
        ['hello', 'shout']
    """

    def __init__(self, kind: str, package: str | None = None):
        self.kind = kind
        self.package = package
        self._entries: dict[str, T] = {}
        self._discovered = package is None
        _REGISTRIES.append(self)

    def _discover(self) -> None:
        """Import the modules of `package` once, which register the bundled entries."""
        if self._discovered:
            return
        # Set first: a module imported here may read the registry while it registers.
        self._discovered = True
        assert self.package is not None
        try:
            folder = importlib.import_module(self.package).__path__
            for module in sorted(info.name for info in pkgutil.iter_modules(folder)):
                if not module.startswith("_"):
                    importlib.import_module(f"{self.package}.{module}")
        except BaseException:
            # A bundled module that fails to import must fail every read, not leave the
            # registry silently short of its entries.
            self._discovered = False
            raise

    @property
    def _sorted(self) -> dict[str, T]:
        self._discover()
        return {name: self._entries[name] for name in sorted(self._entries, key=_natural)}

    @overload
    def register(self, name: str) -> Callable[[V], V]: ...

    @overload
    def register(self, name: str, value: T) -> T: ...

    def register(self, name: str, value: Any = ...) -> Any:
        """Register `value` under `name`; without a value, a decorator that registers what it
        decorates (a class or a function) and returns it unchanged.

        Raises:
            ValueError: If `name` is already registered.
        """
        if value is ...:
            return lambda decorated: self.register(name, decorated)
        if name in self._entries:
            raise ValueError(f"{self.kind} {name!r} is already registered; give it another name")
        self._entries[name] = value
        return value

    def register_named(self, cls: N) -> N:
        """Class decorator: registers `cls` under its `name` attribute and returns it.

        Raises:
            ValueError: If a class of that name is already registered.
        """
        return self.register(cls.name)(cls)

    def unregister(self, name: str) -> T:
        """Remove and return the entry `name` (a test's toy entry, for instance).

        Raises:
            UnknownNameError: If no entry has that name.
        """
        entry = self[name]
        del self._entries[name]
        return entry

    def __getitem__(self, name: str) -> T:
        self._discover()
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise UnknownNameError(f"unknown {self.kind} {name!r}; allowed: "
                                   f"{', '.join(self._sorted)}") from None

    def __contains__(self, name: object) -> bool:
        self._discover()
        return isinstance(name, str) and name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._sorted))

    def __len__(self) -> int:
        self._discover()
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._sorted)})"


@contextlib.contextmanager
def bundled_entries_first() -> Iterator[None]:
    """Around the import of entries from outside the bundled packages (a plugin's): at its end,
    each registry it added to reads its bundled entries, so that a bundled name it took is
    refused now, while its import is the one running, rather than later, in a bundled module.

    Raises:
        ValueError: If a bundled entry has a name registered in the block.
    """
    sizes = {id(registry): len(registry._entries) for registry in _REGISTRIES}
    yield
    for registry in list(_REGISTRIES):
        if len(registry._entries) != sizes.get(id(registry), 0):
            registry._discover()
