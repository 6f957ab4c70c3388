"""Named registries of the extension points (planners, rewards, encoders, part families, stop
rules, sensing models, export formats): a new one is a module that registers itself, and the
config, the CLI and the error messages read the names from the registry (docs/extending.md).

A registry declares its bundled entries by name, each with an entry string
`"package.module:attribute"` (as Gymnasium registers environments) and the facts that listing
them needs (a planner's `usage`), without importing them: listing names, `in` and the messages
that say what is allowed import nothing, and an entry's module is imported on the first lookup
of its name, where it registers the entry. One from outside is a plugin
(`vprobot.extensions.plugins`), registered by being imported.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Generic, Protocol, TypeVar, overload

T = TypeVar("T")
V = TypeVar("V")


class _Named(Protocol):
    """What `Registry.register_named` registers: anything with a name (a class's `name`)."""

    @property
    def name(self) -> str: ...


N = TypeVar("N", bound=_Named)


class UnknownNameError(KeyError, ValueError):
    """A name no entry of a registry has: a user error (ValueError) and a failed lookup
    (KeyError, so that the registry behaves as a mapping)."""

    def __str__(self) -> str:
        # KeyError would quote the message as a key.
        return str(self.args[0])


class Bundled:
    """A bundled entry, declared without importing it.

    Args:
        target: Where it is defined, `"package.module:attribute"`: importing the module
            registers the entry (the attribute is what it registers, or the class of it or the
            function it wraps).
        facts: Those of the registry's facts whose value is not the default (a planner's
            `usage`), so that a listing imports no module; tests/test_registries.py checks them
            against the entry.
    """

    def __init__(self, target: str, **facts: Any):
        module, _, attribute = target.partition(":")
        if not module or not attribute:
            raise ValueError(f"an entry string is 'package.module:attribute', got {target!r}")
        self.target = target
        self.module = module
        self.attribute = attribute
        self.facts: Mapping[str, Any] = facts

    def __repr__(self) -> str:
        return f"Bundled({self.target!r})"


def _natural(name: str) -> list[tuple[int, str | int]]:
    """Sort key of a name in natural order: `R2` before `R10`."""
    return [(1, int(part)) if part.isdigit() else (0, part)
            for part in re.split(r"(\d+)", name) if part]


def abstract_methods(cls: type) -> list[str]:
    """The abstract methods a class leaves undefined, in the order its bases declare them."""
    missing: frozenset[str] = getattr(cls, "__abstractmethods__", frozenset())
    ordered = [name for base in reversed(cls.__mro__) for name in vars(base) if name in missing]
    return list(dict.fromkeys(ordered))


class Registry(Mapping[str, T], Generic[T]):
    """Entries of one kind by name, in natural name order (`R2` before `R10`), so that what a
    message lists does not depend on which module happened to be imported first.

    Args:
        kind: What an entry is, as error messages name it (`planner`, `reward`).
        bundled: The bundled entries by name, each imported on the first lookup of its name
            (a lookup through `values()` or `items()` imports them all); listing the names,
            `in` and `len` import none.
        facts: The attributes of an entry that listings read (`fact`), with their defaults: a
            bundled entry declares those that differ.

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

    def __init__(self, kind: str, bundled: Mapping[str, Bundled] | None = None,
                 facts: Mapping[str, Any] | None = None):
        self.kind = kind
        self.facts: Mapping[str, Any] = dict(facts or {})
        self._bundled: dict[str, Bundled] = dict(bundled or {})
        for name, declared in self._bundled.items():
            if unknown := declared.facts.keys() - self.facts.keys():
                raise ValueError(f"bundled {kind} {name!r} declares {sorted(unknown)}, not "
                                 f"facts of the registry ({sorted(self.facts)})")
        self._entries: dict[str, T] = {}

    @property
    def bundled(self) -> Mapping[str, Bundled]:
        """The declared bundled entries by name."""
        return self._bundled

    def _names(self) -> list[str]:
        return sorted(self._bundled.keys() | self._entries.keys(), key=_natural)

    def _load(self, name: str) -> T:
        """Import the module of the bundled entry `name`, which registers it.

        Raises:
            ImportError: If the module does not register it (its declaration went stale).
        """
        declared = self._bundled[name]
        module = importlib.import_module(declared.module)
        if name not in self._entries or not hasattr(module, declared.attribute):
            raise ImportError(f"bundled {self.kind} {name!r} is declared as {declared.target}, "
                              f"which does not register it")
        return self._entries[name]

    @overload
    def register(self, name: str) -> Callable[[V], V]: ...

    @overload
    def register(self, name: str, value: T) -> T: ...

    def register(self, name: str, value: Any = ...) -> Any:
        """Register `value` under `name`; without a value, a decorator that registers what it
        decorates (a class or a function) and returns it unchanged.

        Raises:
            ValueError: If `name` is already registered, or is a bundled entry's name and this
                is not the import of its module.
            TypeError: If `value` is an abstract class (naming the methods it leaves undefined).
        """
        if value is ...:
            return lambda decorated: self.register(name, decorated)
        declared = self._bundled.get(name)
        # A bundled entry registers while its module is being imported, the one moment the
        # module is in sys.modules and the name not yet registered.
        if name in self._entries or (declared is not None
                                     and declared.module not in sys.modules):
            raise ValueError(f"{self.kind} {name!r} is already registered; give it another name")
        if inspect.isclass(value):
            self.check_concrete(name, value)
        self._entries[name] = value
        return value

    def check_concrete(self, name: str, cls: type) -> None:
        """Refuse an abstract class at its registration, not when it is first used.

        Raises:
            TypeError: If `cls` is abstract, naming the methods it leaves undefined.
        """
        if inspect.isabstract(cls):
            raise TypeError(f"{self.kind} {name!r} is abstract: it does not define "
                            f"{', '.join(abstract_methods(cls))}")

    def register_named(self, cls: N) -> N:
        """Class decorator: registers `cls` under its `name` attribute and returns it.

        Raises:
            ValueError: If a class of that name is already registered.
            TypeError: If `cls` is abstract.
        """
        return self.register(cls.name)(cls)

    def unregister(self, name: str) -> T:
        """Remove and return the entry `name` (a test's toy entry, for instance).

        Raises:
            UnknownNameError: If no entry has that name.
        """
        entry = self[name]
        del self._entries[name]
        self._bundled.pop(name, None)
        return entry

    def fact(self, name: str, key: str) -> Any:
        """The attribute `key` (one of `facts`) of the entry `name`: from its declaration for a
        bundled entry (no import), else from the entry.

        Raises:
            UnknownNameError: If no entry has that name.
        """
        declared = self._bundled.get(name)
        if declared is not None and name not in self._entries:
            return declared.facts.get(key, self.facts[key])
        return getattr(self[name], key)

    def __getitem__(self, name: str) -> T:
        if isinstance(name, str) and name in self._entries:
            return self._entries[name]
        if isinstance(name, str) and name in self._bundled:
            return self._load(name)
        raise UnknownNameError(f"unknown {self.kind} {name!r}; allowed: "
                               f"{', '.join(self._names())}")

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (name in self._entries or name in self._bundled)

    def __iter__(self) -> Iterator[str]:
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._names())})"
