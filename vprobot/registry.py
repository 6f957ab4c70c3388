"""Named registries of the extension points (planners, rewards, encoders, part families, stop
rules): a new one is a module that registers itself, and the config, the CLI and the error
messages read the names from the registry (docs/extending.md).
"""

from __future__ import annotations

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


class Registry(Mapping[str, T], Generic[T]):
    """Entries of one kind by name, in registration order.

    Args:
        kind: What an entry is, as error messages name it (`planner`, `reward`).

    Example:
        >>> GREETINGS: Registry[str] = Registry("greeting")
        >>> GREETINGS.register("hello", "Hello!")
        'Hello!'
        >>> @GREETINGS.register("shout")
        ... def shout() -> str:
        ...     return "HEY"
        >>> list(GREETINGS)
        ['hello', 'shout']
    """

    def __init__(self, kind: str):
        self.kind = kind
        self._entries: dict[str, T] = {}

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
            raise ValueError(f"{self.kind} {name!r} is already registered")
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
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            raise UnknownNameError(f"unknown {self.kind} {name!r}; allowed: "
                                   f"{', '.join(self._entries)}") from None

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}: {', '.join(self._entries)})"
