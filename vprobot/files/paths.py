"""Locations of the files vprobot ships inside the package (robots, motors, configs).

They are package data, found through `importlib.resources`, so that a wheel works as well as an
editable checkout (where `assets/` and `configs/` at the repository root link here).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from importlib.resources import files
from pathlib import Path

PACKAGE_DIR = Path(str(files("vprobot")))
ASSETS_DIR = PACKAGE_DIR / "assets"
ROBOTS_DIR = ASSETS_DIR / "robots"
MOTORS_DIR = ASSETS_DIR / "motors"
OBJECTS_DIR = ASSETS_DIR / "objects"
"""Bundled non-motor objects (bracket, pipe tee, torus) for testing generalisation."""
AGENTS_DIR = ASSETS_DIR / "agents"
"""Bundled trained agents, one run folder each."""
CONFIGS_DIR = PACKAGE_DIR / "configs"
DEFAULT_CONFIG = CONFIGS_DIR / "default.yaml"
SENSORS_DIR = CONFIGS_DIR / "sensors"
"""Sensor presets, one YAML file per device: `sensor: NAME` in a config, `--sensor NAME`."""
CELLS_DIR = CONFIGS_DIR / "cells"
"""Bundled cell files, one YAML file per cell: `cell: NAME` in a config, `--cell NAME`."""
PROFILES_DIR = CONFIGS_DIR / "agents"
"""Agent profiles: the configs `vprobot train` and the studies start from."""
EPISODES_DIR = CONFIGS_DIR / "episodes"
"""Bundled episode lists, one JSON file each."""
BUNDLED_EPISODE_LISTS = {
    name: EPISODES_DIR / f"{name}.json"
    for name in ("test-v1", "shapes-v1", "families-test-v1", "validation-v1", "validation-v2",
                 "validation-v3")}
"""The bundled episode lists by name (`vprobot evaluate --episodes NAME`, `agent.test_lists`):
the test motors, the non-motor shapes, the test families' instances, and the validation lists of
splits v1 and v2 (`vprobot.parts.splits`)."""
SPLITS_DIR = CONFIGS_DIR / "splits"
ESTIMATOR_DIR = ASSETS_DIR / "estimator"
"""The bundled model-free coverage estimator (`--stop estimate`)."""
DEFAULT_MOTOR = MOTORS_DIR / "test" / "motor_000.stl"
"""The bundled motor that commands use when no mesh is given."""
DESCRIPTION_FILE = "robot.yaml"
"""The file that makes a folder a robot folder (`vprobot.robots.description` reads it)."""

CACHE_ENV_VAR = "VPROBOT_CACHE_DIR"


def available_robots() -> list[str]:
    """Names of the bundled robot folders (those holding a `robot.yaml`)."""
    return sorted(path.parent.name for path in ROBOTS_DIR.glob(f"*/{DESCRIPTION_FILE}"))


def available_sensors() -> list[str]:
    """Names of the sensor presets in `configs/sensors/`, sorted."""
    return sorted(path.stem for path in SENSORS_DIR.glob("*.yaml"))


def available_cells() -> list[str]:
    """Names of the cell files in `configs/cells/`, sorted."""
    return sorted(path.stem for path in CELLS_DIR.glob("*.yaml"))


def names_a_path(text: str) -> bool:
    """Whether the user wrote a path rather than a bundled name: with a path separator, or
    starting with `.` or `~` (`./cpu` is the folder `cpu` here, not the bundled agent `cpu`)."""
    return text.startswith((".", "~")) or "/" in text or os.sep in text


def bundled_or_path(value: str | Path, bundled: Mapping[str, Path], what: str,
                    kind: str = "file") -> Path:
    """Resolve a bundled name, else an existing path (a folder when `kind` ends in "folder");
    an explicit path (`names_a_path`) is always the path.

    Args:
        value: What the user wrote.
        bundled: The bundled names and their paths.
        what: What is named, for the error ("robot", "episode list", ...).
        kind: What a path must be, for the error ("file", "robot folder", ...).

    Raises:
        ValueError: If `value` is neither; the message names it and lists the bundled names.
    """
    if str(value) in bundled and not names_a_path(str(value)):
        return bundled[str(value)]
    path = Path(value).expanduser()
    try:
        if path.is_dir() if kind.endswith("folder") else path.is_file():
            return path
    except OSError:
        pass  # a name the system cannot look up (too long, say) is no path either
    from vprobot.files.schema import brief  # its YAML reader would slow every command's start

    raise ValueError(f"unknown {what} {brief(str(value))}: neither a bundled {what} "
                     f"({', '.join(bundled)}) nor a {kind}")


def cache_root() -> Path:
    """Where vprobot keeps what it builds once (ground truth, generated objects):
    `$VPROBOT_CACHE_DIR`, or `~/.cache/vprobot`."""
    root = os.environ.get(CACHE_ENV_VAR)
    return Path(root).expanduser() if root else Path.home() / ".cache" / "vprobot"
