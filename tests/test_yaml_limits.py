"""YAML a user gives (configs, sensor presets) cannot make vprobot hang or fill the memory: aliases
repeat a bounded number of values, and messages quote values briefly."""

from __future__ import annotations

import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from vprobot.config import ConfigError, load_config, sensor_preset
from vprobot.files import schema
from vprobot.files.schema import parse_yaml

MEMORY_LIMIT_BYTES = 4 << 30
"""Address space of a child that reads a bomb: bounds what a regression would take."""


def alias_bomb(levels: int) -> str:
    """A flow list of `levels` anchored lists, each nine aliases of the one before: 9^levels
    values from a few hundred bytes."""
    anchored = ["&l0 [1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    anchored += [f"&l{level} [{', '.join([f'*l{level - 1}'] * 9)}]"
                 for level in range(1, levels)]
    return f"[{', '.join(anchored)}]"


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))


def _vprobot(*argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """vprobot in a child process with bounded memory, ended after a generous minute (the
    landed code ran past it, formatting the expanded value)."""
    return subprocess.run([sys.executable, "-m", "vprobot.cli", *argv], cwd=cwd,
                          capture_output=True, text=True, timeout=60, preexec_fn=_limit_memory)


def test_an_alias_bomb_in_a_sensor_preset_is_one_line_naming_the_file(tmp_path: Path) -> None:
    (tmp_path / "bomb.yaml").write_text(f"resolution: {alias_bomb(9)}\n")
    done = _vprobot("cell", "--sensor", "bomb.yaml", cwd=tmp_path)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    repeated = re.fullmatch(r"vprobot cell: error: --sensor: bomb\.yaml: its YAML aliases repeat "
                            r"([\d,]+) values; vprobot reads at most 10,000 repeated by aliases "
                            r"\(an alias of an alias multiplies them\)\n", done.stderr)
    # The last level alone repeats 9^9 ones.
    assert repeated is not None and int(repeated[1].replace(",", "")) > 9 ** 9


def test_an_alias_bomb_in_a_config_is_one_line_naming_the_file(tmp_path: Path) -> None:
    (tmp_path / "bomb.yaml").write_text(f"sensor:\n  resolution: {alias_bomb(9)}\n")
    done = _vprobot("cell", "--config", "bomb.yaml", cwd=tmp_path)
    assert done.returncode == 2 and len(done.stderr.splitlines()) == 1
    assert done.stderr.startswith("vprobot cell: error: bomb.yaml: its YAML aliases repeat ")


def test_aliases_within_the_limit_read_and_the_message_quotes_the_value_briefly(
        tmp_path: Path) -> None:
    # Four levels repeat 9^2 + 9^3 + 9^4 = 7,371 values: read, but 6,561 ones quoted in full
    # made a message of 20,000 characters.
    assert sum(9 ** level for level in range(2, 5)) <= schema.ALIAS_VALUES_LIMIT
    preset = tmp_path / "preset.yaml"
    preset.write_text(f"resolution: {alias_bomb(4)}\n")
    with pytest.raises(ConfigError) as error:
        sensor_preset(str(preset))
    assert str(error.value) == ("sensor.resolution must be a list of 2 values, got "
                                "[[1, 1, 1, 1, 1, 1, ...], [[1, 1, 1, 1, 1, 1, ...], "
                                "[1, 1, 1, 1, 1, 1, ...], ...")


def test_brief_cuts_long_and_nested_values_without_formatting_them_whole() -> None:
    assert schema.brief("x" * 1000) == "'" + "x" * 37 + "..." + "x" * 38 + "'"
    assert schema.brief(list(range(10 ** 6))) == "[0, 1, 2, 3, 4, 5, ...]"
    assert schema.brief(0.25) == "0.25" and schema.brief("short") == "'short'"
    assert len(schema.brief({"key": ["a" * 200] * 50})) == 80


def test_a_recursive_alias_and_deep_nesting_are_errors_naming_the_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"^a\.yaml: an alias lies inside its own anchor "
                                          r"\(line 2\)"):
        parse_yaml("sensor:\n  resolution: &r [*r, 1]\n", "a.yaml")
    deep = tmp_path / "deep.yaml"
    deep.write_text("sensor: " + "[" * 10_000)
    with pytest.raises(ConfigError, match=r"deep\.yaml: not valid YAML: nested too deeply"):
        load_config(deep)


def test_a_character_yaml_refuses_is_an_error_naming_the_source() -> None:
    # PyYAML's reader refuses it as the loader is made, before any node is read (found by
    # tests/test_fuzz.py once the loader was made outside the error handling).
    with pytest.raises(ConfigError, match=r"^x\.yaml: not valid YAML: special characters"):
        parse_yaml("\x1f", "x.yaml")
