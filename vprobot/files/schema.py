"""The schema vprobot's YAML files are validated with: strict mappings into frozen dataclasses.

The base of every file format (configs, profiles, studies, splits, robot descriptions): it imports
nothing of vprobot, so that the registries the config checks names against can use it without
importing the config.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import reprlib
import types
import typing
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import yaml

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]

RESOLVE = "vprobot.files.schema.resolve"
"""Field metadata key: a function `(value, key) -> value` applied to the raw value first."""

FORMERLY = "vprobot.files.schema.formerly"
"""Field metadata key: the field's former name, still read for one release (with a note)."""


class ConfigError(ValueError):
    """A configuration file or mapping does not match the schema."""


BRIEF_CHARS = 80
"""The most characters of a value a message quotes (`brief`)."""

_BRIEF_REPR = reprlib.Repr()
# Nested lists are cut level by level while the text is built: a value with millions of items
# is never formatted whole.
_BRIEF_REPR.maxlevel = 3
_BRIEF_REPR.maxlist = _BRIEF_REPR.maxtuple = _BRIEF_REPR.maxdict = _BRIEF_REPR.maxset = 6
_BRIEF_REPR.maxstring = _BRIEF_REPR.maxother = _BRIEF_REPR.maxlong = BRIEF_CHARS


def brief(value: Any, limit: int = BRIEF_CHARS) -> str:
    """`repr(value)` for a message, at most `limit` characters ("..." where it is cut): every
    message that quotes a value the user gave quotes it through here."""
    text = _BRIEF_REPR.repr(value)
    return text if len(text) <= limit else f"{text[:limit - 3]}..."


ALIAS_VALUES_LIMIT = 10_000
"""The most values YAML aliases may repeat in one document. An alias repeats its anchor's whole
value, and an alias of an alias multiplies: nine levels of nine aliases make 9^9 values (an
"alias bomb") from a few hundred bytes, which no check could walk or quote. vprobot's own files
use none; a merge key (`<<: *defaults`) repeats a few."""


def _expanded_values(root: yaml.Node, source: str) -> tuple[int, int]:
    """How many values the document `root` holds with every alias written out, and how many
    it holds as written (each anchored node once).

    Raises:
        ConfigError: If an alias lies inside its own anchor (endless repetition), naming
            `source` and the anchor's line.
    """
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()

    def size(node: yaml.Node) -> int:
        if id(node) in sizes:
            return sizes[id(node)]
        if id(node) in open_nodes:
            raise ConfigError(f"{source}: an alias lies inside its own anchor (line "
                              f"{node.start_mark.line + 1}), which would repeat it endlessly")
        open_nodes.add(id(node))
        if isinstance(node, yaml.MappingNode):
            total = 1 + sum(size(key) + size(value) for key, value in node.value)
        elif isinstance(node, yaml.SequenceNode):
            total = 1 + sum(size(item) for item in node.value)
        else:
            total = 1
        open_nodes.discard(id(node))
        sizes[id(node)] = total
        return total

    return size(root), len(sizes)


class _UniqueKeyLoader(yaml.SafeLoader):
    """YAML's safe loader, refusing a key given twice in one mapping (which YAML forbids, and
    PyYAML would read as the last one, silently dropping the first)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        lines: dict[Any, int] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue  # `<<: *defaults` may be overridden key by key
            key = self.construct_object(key_node, deep=True)
            try:
                if key in lines:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {brief(key)} is given twice (first on line {lines[key]})",
                        key_node.start_mark)
                lines[key] = key_node.start_mark.line + 1
            except TypeError:
                continue  # an unhashable key, which the safe loader refuses itself
        return super().construct_mapping(node, deep)


def _invalid(error: yaml.YAMLError, source: str) -> ConfigError:
    """PyYAML's error as one line naming the source (and the line where known)."""
    where = getattr(error, "problem_mark", None)
    line = f" (line {where.line + 1})" if where is not None else ""
    problem = getattr(error, "problem", None) or getattr(error, "reason", None)
    return ConfigError(f"{source}: not valid YAML{line}: {problem or type(error).__name__}")


def parse_yaml(text: str, source: str) -> Any:
    """The YAML document in `text`; `source` (a file, an option) names it in errors.

    Raises:
        ConfigError: If the text is not valid YAML, gives a key twice in one mapping, nests
            too deeply, or its aliases repeat more than `ALIAS_VALUES_LIMIT` values (or
            themselves); the message names the source (and the line where known).
    """
    try:
        # The reader refuses non-printable characters as it is made.
        loader = _UniqueKeyLoader(text)
    except yaml.YAMLError as error:
        raise _invalid(error, source) from None
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        expanded, written = _expanded_values(node, source)
        if expanded - written > ALIAS_VALUES_LIMIT:
            raise ConfigError(f"{source}: its YAML aliases repeat {expanded - written:,} "
                              f"values; vprobot reads at most {ALIAS_VALUES_LIMIT:,} repeated by "
                              f"aliases (an alias of an alias multiplies them)")
        return loader.construct_document(node)
    except yaml.YAMLError as error:
        raise _invalid(error, source) from None
    except RecursionError:
        # PyYAML composes nested collections recursively.
        raise ConfigError(f"{source}: not valid YAML: nested too deeply") from None
    finally:
        loader.dispose()


def read_yaml(path: str | Path) -> Any:
    """The YAML document of a file: every config, profile, study, split and robot description
    is read through here.

    Raises:
        OSError: If the file cannot be read.
        ConfigError: If it is not UTF-8 text or not valid YAML (naming the file and the line).
    """
    try:
        text = Path(path).read_text()
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not valid YAML: not UTF-8 text") from None
    # A document of the caller's own: the parse is shared by every read of the same text.
    return copy.deepcopy(_parsed_yaml(text, str(path)))


@functools.lru_cache(maxsize=32)
def _parsed_yaml(text: str, source: str) -> Any:
    """`parse_yaml`, once per text and source: a process reads the same configs again and again
    (each `load_config` reads its file and the default config; PyYAML takes tens of ms a
    config). Errors are not kept: they are raised anew each time."""
    return parse_yaml(text, source)


def check_within(key: str, value: float, low: float, high: float, unit: str) -> None:
    """Raise ConfigError unless low <= value <= high (the message names the key and unit)."""
    if not low <= value <= high:
        raise ConfigError(f"{key} must lie in [{low:g}, {high:g}] {unit}, got {brief(value)}")


def _as_written(value: Any, key: str) -> Any:
    return value


def _convert(value: Any, annotation: Any, key: str) -> Any:
    """Validate `value` against a type annotation and convert it (lists become tuples)."""
    origin = typing.get_origin(annotation)
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation):
        if not isinstance(value, Mapping):
            raise ConfigError(f"{key} must be a mapping, got {brief(value)}")
        return from_mapping(annotation, value, key)
    if origin is Literal:
        allowed = typing.get_args(annotation)
        if value not in allowed:
            raise ConfigError(f"{key} must be one of {list(allowed)}, got {brief(value)}")
        return value
    if origin is tuple:
        item_types = typing.get_args(annotation)
        if len(item_types) == 2 and item_types[1] is Ellipsis:
            # A list of records (a cell's static objects) may be empty; a list of values not.
            records = dataclasses.is_dataclass(item_types[0])
            if not isinstance(value, list | tuple) or not (value or records):
                raise ConfigError(f"{key} must be a non-empty list, got {brief(value)}")
            item_types = (item_types[0],) * len(value)
        if not isinstance(value, list | tuple) or len(value) != len(item_types):
            raise ConfigError(f"{key} must be a list of {len(item_types)} values, got "
                              f"{brief(value)}")
        return tuple(
            _convert(item, item_type, f"{key}[{index}]")
            for index, (item, item_type) in enumerate(zip(value, item_types, strict=True))
        )
    if origin is dict:
        # An open mapping (an encoder's settings), checked by whoever knows its keys.
        if not isinstance(value, Mapping) or not all(isinstance(name, str) for name in value):
            raise ConfigError(f"{key} must be a mapping of names to values, got {brief(value)}")
        return dict(value)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in typing.get_args(annotation):
            return None
        (inner,) = [arg for arg in typing.get_args(annotation) if arg is not type(None)]
        return _convert(value, inner, key)
    if annotation is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"{key} must be a number, got {brief(value)}")
        if not math.isfinite(value):
            raise ConfigError(f"{key} must be finite, got {brief(value)}")
        return float(value)
    if annotation is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key} must be an integer, got {brief(value)}")
        return value
    if annotation is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {brief(value)}")
        return value
    if annotation is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {brief(value)}")
        return value
    raise TypeError(f"unsupported annotation {annotation!r} for {key}")


def with_current_keys(cls: type, data: Mapping[str, Any], key: str = "") -> dict[str, Any]:
    """`data` with each former name of a field of dataclass `cls` (its `FORMERLY` metadata)
    replaced by the field's name, with a `FutureWarning` that names both.

    Raises:
        ConfigError: If `data` has both names of a field.
    """
    prefix = f"{key}." if key else ""
    renamed = dict(data)
    for field in dataclasses.fields(cls):
        former = field.metadata.get(FORMERLY)
        if former is None or former not in renamed:
            continue
        if field.name in renamed:
            raise ConfigError(f"{prefix}{former} and {prefix}{field.name} are both set; "
                              f"{prefix}{former} is the former name of {prefix}{field.name}: "
                              f"keep {prefix}{field.name} only")
        # A warning, not an error, for one release: configs and runs written before stay usable.
        warnings.warn(f"{prefix}{former} is now called {prefix}{field.name}; the old name "
                      f"will not be read after the next release", FutureWarning, stacklevel=2)
        renamed[field.name] = renamed.pop(former)
    return renamed


def from_mapping(cls: type, data: Mapping[str, Any], key: str = "") -> Any:
    """Build dataclass `cls` from a mapping, rejecting unknown keys.

    Args:
        cls: A dataclass type whose fields are annotated with the types `_convert` knows.
            A field whose metadata has `RESOLVE` takes the raw value through that function
            `(value, key) -> value` first (e.g. a preset name into its mapping).
        data: Keys and values; missing keys take their defaults.
        key: Dotted prefix for error messages.

    Raises:
        ConfigError: On unknown keys, wrong types or invalid values.
    """
    data = with_current_keys(cls, data, key)
    hints = typing.get_type_hints(cls)
    resolvers = {field.name: field.metadata.get(RESOLVE, _as_written)
                 for field in dataclasses.fields(cls)}
    fields = set(resolvers)
    unknown = sorted(set(data) - fields)
    if unknown:
        where = f"section '{key}'" if key else "the top level"
        raise ConfigError(
            f"unknown key {brief(unknown[0])} in {where}; allowed keys: {', '.join(sorted(fields))}"
        )
    prefix = f"{key}." if key else ""
    values = {name: _convert(resolvers[name](value, prefix + name), hints[name], prefix + name)
              for name, value in data.items()}
    try:
        return cls(**values)
    except ConfigError as error:
        # A record's own check knows its keys but not where the record sits in the file.
        if not key or str(error).startswith(key):
            raise
        raise ConfigError(f"{key}: {error}") from None
