"""What the docs claim to list is all there: `configs/default.yaml` lists every setting of the
schema with its default (README, docs/running.md), and docs/README.md's Layout names every
module and subpackage of `vprobot/`."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Any

from vprobot.config import Config, load_config
from vprobot.paths import DEFAULT_CONFIG
from vprobot.schema import read_yaml

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "vprobot"


def settings(cls: type, prefix: str = "") -> set[str]:
    """Every setting of the config dataclass `cls`, dotted (`env.reward`); a section is a
    field whose default is itself a dataclass."""
    keys = set()
    for field in dataclasses.fields(cls):
        default = field.default_factory() if callable(field.default_factory) else field.default
        if dataclasses.is_dataclass(default):
            keys |= settings(type(default), f"{prefix}{field.name}.")
        else:
            keys.add(prefix + field.name)
    return keys


def written(data: dict[str, Any], prefix: str = "") -> set[str]:
    """Every key a YAML mapping sets, dotted; a nested mapping is a section."""
    keys = set()
    for name, value in data.items():
        if isinstance(value, dict):
            keys |= written(value, f"{prefix}{name}.")
        else:
            keys.add(prefix + name)
    return keys


def test_default_yaml_lists_every_setting_of_the_schema() -> None:
    missing = settings(Config) - written(read_yaml(DEFAULT_CONFIG))
    assert not missing, f"configs/default.yaml lacks {sorted(missing)}"


def test_default_yaml_values_are_the_schema_defaults() -> None:
    assert load_config(DEFAULT_CONFIG) == Config()


def layout() -> str:
    text = (ROOT / "docs" / "README.md").read_text()
    section = text.split("\n## Layout\n", 1)[1]
    return section.split("\n## ", 1)[0]


def test_docs_layout_names_every_module_and_subpackage() -> None:
    named = set(re.findall(r"`([\w./-]+)`", layout()))
    modules = {path.stem for path in PACKAGE.glob("*.py") if path.stem != "__init__"}
    packages = {f"{path.parent.name}/" for path in PACKAGE.glob("*/__init__.py")}
    missing = sorted((modules | packages) - named)
    assert not missing, f"docs/README.md#layout does not name {missing}"
