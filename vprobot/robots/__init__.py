"""Robots: the bundled robot folders, user robot folders and their descriptions.

A robot is named either by a bundled folder under `assets/robots/` (`ur5`, `ur10`, `panda`) or by
the path of a robot folder of the same layout, e.g. one written by `vprobot robots import`.
"""

from __future__ import annotations

import functools
from pathlib import Path

from vprobot.files.paths import ROBOTS_DIR, available_robots, bundled_or_path
from vprobot.robots.description import DESCRIPTION_FILE, RobotDescription

__all__ = ["RobotDescription", "available_robots", "is_bundled", "load_robot", "robot_folder"]


def robot_folder(robot: str) -> Path:
    """The folder of a bundled robot's name, or `robot` itself when it is a folder.

    Raises:
        ValueError: If `robot` is neither; the message lists the bundled robots.
    """
    return bundled_or_path(robot, {name: ROBOTS_DIR / name for name in available_robots()},
                           "robot", "robot folder")


def is_bundled(robot: RobotDescription) -> bool:
    """Whether the description is a bundled robot's (which its name alone names)."""
    return robot.folder.resolve() == (ROBOTS_DIR / robot.name).resolve()


def load_robot(robot: str) -> RobotDescription:
    """The checked description of a bundled robot or robot folder, read once per process (a
    description is immutable; an edited `robot.yaml` is read again).

    Raises:
        ValueError: If the robot is unknown or its folder or `robot.yaml` is incomplete.
    """
    folder = robot_folder(robot)
    try:
        status = (folder / DESCRIPTION_FILE).stat()
    except OSError:
        return RobotDescription.load(folder)  # which names what is missing
    return _load_description(folder, folder.resolve(), status.st_mtime_ns, status.st_size)


@functools.lru_cache(maxsize=32)
def _load_description(folder: Path, resolved: Path, modified_ns: int,
                      size: int) -> RobotDescription:
    """`RobotDescription.load(folder)`, cached: the config, the cell and the fit checks of one
    plan all ask for the robot. The key holds the folder as given (the description keeps it),
    the folder it resolves to (a relative one moves with the working folder) and the time and
    size of its `robot.yaml`."""
    return RobotDescription.load(folder)
