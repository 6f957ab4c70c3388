"""How much of the view sphere an arm reaches: the survey `vprobot cell` prints and the
kinematics benchmark times."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from tqdm import tqdm

from vprobot.cell.scene import Cell
from vprobot.config import Config
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics.arm import RobotArm
from vprobot.kinematics.ik import SensorTarget
from vprobot.parts.loading import load_mesh

VIEW_SPHERE_CANDIDATES = 900
VIEW_SPHERE_MAX_POLAR_DEG = 120.0  # from the top down to 30 degrees below the equator


def default_cell(config: Config, robot: str | None = None) -> Cell:
    """The configured cell holding the bundled default motor, optionally with another robot
    (standing at its own placement)."""
    if robot is not None:
        config = dataclasses.replace(config, cell=dataclasses.replace(
            config.cell, robot=robot, robot_base_position_m=None, robot_base_yaw_deg=None,
            robot_base_tilt_deg=None))
    return Cell(config, load_mesh(DEFAULT_MOTOR).mesh)


def view_sphere_targets(cell: Cell, count: int = VIEW_SPHERE_CANDIDATES) -> list[SensorTarget]:
    """Look-at targets spread evenly at the working distance around the object centre."""
    directions = sphere_directions(count, np.deg2rad(VIEW_SPHERE_MAX_POLAR_DEG))
    distance = cell.config.sensor.working_distance_m
    center = cell.object_center
    return [SensorTarget.look_at(center + distance * d, center) for d in directions]


def view_sphere_survey(arm: RobotArm, targets: Sequence[SensorTarget],
                       progress: bool = True, label: str = "") -> dict[str, Any]:
    """Reach every target from home; fraction reachable, the count of each failure reason
    (`RobotArm.reach`'s, most frequent first) and verdict times."""
    reasons: dict[str, int] = {}
    reachable: list[bool] = []
    reachable_ms: list[float] = []
    unreachable_ms: list[float] = []
    for target in tqdm(targets, desc=f"view sphere {label}", disable=not progress, leave=False):
        start = time.perf_counter()
        result = arm.reach(target, arm.joints.start)
        elapsed = (time.perf_counter() - start) * 1e3
        reachable.append(result.reachable)
        (reachable_ms if result.reachable else unreachable_ms).append(elapsed)
        if not result.reachable:
            reasons[str(result.reason)] = reasons.get(str(result.reason), 0) + 1
    return {
        "fraction": len(reachable_ms) / len(targets),
        "reachable": reachable,
        "reasons": dict(sorted(reasons.items(), key=lambda item: -item[1])),
        "reachable_ms": reachable_ms,
        "unreachable_ms": unreachable_ms,
    }
