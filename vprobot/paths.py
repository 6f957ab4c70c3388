"""Locations of the files vprobot ships next to the package (assets, configs)."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
ASSETS_DIR = REPO_ROOT / "assets"
ROBOTS_DIR = ASSETS_DIR / "robots"
MOTORS_DIR = ASSETS_DIR / "motors"
CONFIGS_DIR = REPO_ROOT / "configs"
DEFAULT_MOTOR = MOTORS_DIR / "test" / "motor_000.stl"
"""The bundled motor that commands use when no mesh is given."""
