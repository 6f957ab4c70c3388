"""View plans as JSON for a real cell (SPEC section 12)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.episode import EpisodeRecord
from vprobot.files import atomic_output
from vprobot.geometry import Pose
from vprobot.inspection import MotorScene
from vprobot.kinematics import TravelCost
from vprobot.robots import FLANGE_FRAME
from vprobot.scene import Cell


@dataclasses.dataclass(frozen=True)
class PlannedView:
    """One view of a plan: the requested sensor pose and what the robot made of it.

    Attributes:
        pose: Sensor pose in the world (reached pose when reachable, else the requested one).
        joints: Joint configuration reaching it (None when unreachable).
        reachable: Whether the robot reaches it collision-free; None when no robot was involved
            (a free-flying sensor).
        reason: Why not, when unreachable.
        coverage: Cumulative coverage after this view, when known.
        travel: Travel from the previous view, when known.
    """

    pose: Pose
    joints: np.ndarray | None
    reachable: bool | None
    reason: str | None = None
    coverage: float | None = None
    travel: TravelCost | None = None

    def as_dict(self) -> dict[str, Any]:
        view: dict[str, Any] = {
            "position": _floats(self.pose.position),
            "quaternion": _floats(self.pose.quaternion),
            "joints": None if self.joints is None else _floats(self.joints),
            "reachable": self.reachable,
            "reason": self.reason,
        }
        if self.coverage is not None:
            view["coverage"] = float(self.coverage)
        if self.travel is not None:
            view["travel"] = self.travel.as_dict()
        return view


def _floats(values: np.ndarray) -> list[float]:
    return [float(value) for value in np.asarray(values).ravel()]


def robot_block(cell: Cell) -> dict[str, Any]:
    """The robot: name, base pose, joint names and the sensor mount on the flange frame."""
    base, mount = cell.robot_base, cell.sensor_mount
    return {
        "name": cell.robot,
        "base_position": _floats(base.position),
        "base_quaternion": _floats(base.quaternion),
        "joint_names": list(cell.joints.names),
        "sensor_mount": {
            "parent": FLANGE_FRAME,
            "position": _floats(mount.position),
            "quaternion": _floats(mount.quaternion),
        },
    }


def sensor_block(cell: Cell) -> dict[str, Any]:
    sensor = cell.config.sensor
    return {
        "resolution": list(sensor.resolution),
        "fov_deg": list(sensor.fov_deg),
        "range": [sensor.near_m, sensor.far_m],
        "frame": "+z viewing direction, +x image right, +y image down",
    }


def plan_document(
    cell: Cell,
    views: list[PlannedView],
    object_block: dict[str, Any] | None = None,
    coverage: float | None = None,
) -> dict[str, Any]:
    """Assemble the plan JSON document.

    Args:
        cell: The cell the plan was made in.
        views: The views in execution order.
        object_block: How the object's mesh file is placed in the world, when there is one.
        coverage: Final cumulative coverage, when known.
    """
    document: dict[str, Any] = {
        "object": object_block,
        "robot": robot_block(cell),
        "sensor": sensor_block(cell),
        "views": [view.as_dict() for view in views],
        "coverage": coverage,
    }
    return document


def planned_views(record: EpisodeRecord, robot: bool = True) -> list[PlannedView]:
    """The views of an episode as plan views.

    A reached view carries the sensor pose it was acquired from and the joints that reach it; an
    unreached one its requested pose and no joints. Without the robot (`robot=False`, a
    free-flying sensor) views carry their pose only and `reachable` is None.
    """
    views = []
    for view in record.views:
        reached = robot and view.reachable
        pose = view.sensor_pose if view.sensor_pose is not None else view.requested
        views.append(PlannedView(
            pose=pose,
            joints=view.joints if reached else None,
            reachable=view.reachable if robot else None,
            reason=view.reason if robot else None,
            coverage=view.coverage,
            travel=view.travel,
        ))
    return views


def episode_document(scene: MotorScene, record: EpisodeRecord, robot: bool = True,
                     metadata: dict[str, Any] | None = None) -> dict[str, Any]:
    """The plan JSON of an episode: object placement, robot, sensor, views, final coverage.

    Args:
        scene: The motor scene the episode ran in.
        record: The episode.
        robot: Whether the robot reached the views (False: free-flying sensor).
        metadata: Extra top-level entries (planner, mode, seed, ...).
    """
    document = plan_document(scene.cell, planned_views(record, robot),
                             scene.object_block(record.object_pose), record.coverage)
    document["start_joints"] = _floats(record.start_joints)
    document.update(metadata or {})
    return document


def write_json(path: str | Path, document: dict[str, Any]) -> Path:
    """Write `document` to `path` atomically (no half-written file on error).

    Raises:
        ValueError: If the parent folder does not exist or `path` is a folder.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"output path {path} is a folder; give a file name such as plan.json")
    if not path.parent.is_dir():
        raise ValueError(f"output folder {path.parent} does not exist")
    text = json.dumps(document, indent=2, allow_nan=False)
    with atomic_output(path) as temporary:
        temporary.write_text(text + "\n")
    return path
