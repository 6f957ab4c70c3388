"""The robots vprobot ships: one folder each under `assets/robots/` (MuJoCo Menagerie layout)."""

from __future__ import annotations

from pathlib import Path

from vprobot.paths import ROBOTS_DIR

FLANGE_FRAME = "tool0"
"""Name of the flange frame in every robot description (the UR controller's tool0)."""


def available_robots() -> list[str]:
    """Names of the robot folders that hold a `scene.xml`."""
    return sorted(path.parent.name for path in ROBOTS_DIR.glob("*/scene.xml"))


def scene_path(robot: str) -> Path:
    """Path of the robot's `scene.xml`.

    Raises:
        ValueError: If no such robot is bundled; the message lists the available ones.
    """
    robots = available_robots()
    if robot not in robots:
        raise ValueError(f"unknown robot {robot!r}; available robots: {', '.join(robots)}")
    return ROBOTS_DIR / robot / "scene.xml"
