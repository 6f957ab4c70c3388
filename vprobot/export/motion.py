"""A plan JSON's motion, timed: what every export format writes and the replay check replays.

Everything comes from the plan alone (docs/plan-format.md): the corners of every move, the
return, the robot's limits and the sensor's acquisition time; the time law is
`vprobot.kinematics.trajectory.time_plan` (docs/motion.md#the-time-law), the one that gave the
plan's `cycle_time`.
"""

from __future__ import annotations

import dataclasses
import re
from typing import Any

import numpy as np

from vprobot.kinematics.trajectory import MotionLimits, TimedPlan, time_plan

UR_ROBOT = re.compile(r"ur\d+e?", re.IGNORECASE)
"""Names of Universal Robots arms, the robots a URScript program runs on (ur5, ur10, ur10e...)."""


@dataclasses.dataclass(frozen=True)
class ViewStop:
    """One acquisition of the plan: which view, where the robot stands, the sensor pose there.

    Attributes:
        view: Index into the plan's `views`.
        joints: The configuration the robot acquires from (rad).
        position: The plan's sensor position there (m, world).
        quaternion: The plan's sensor orientation there (w, x, y, z).
    """

    view: int
    joints: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray


@dataclasses.dataclass(frozen=True)
class PlanMotion:
    """A plan's cycle, timed.

    Attributes:
        robot: The robot's name.
        limits: The motion limits it was timed under (the plan's `robot.limits`).
        moves: The approach, the moves to the later views and the return, each as its corners
            (m, dof), in the order the robot runs them.
        stops: The acquisitions, one per move but the return, in view order.
        acquisition_time_s: How long the robot stands at each view (the plan's sensor's).
        timed: The moves timed, stopping `acquisition_time_s` at every view.
    """

    robot: str
    limits: MotionLimits
    moves: tuple[np.ndarray, ...]
    stops: tuple[ViewStop, ...]
    acquisition_time_s: float
    timed: TimedPlan

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self.timed.joint_names


def _array(value: Any, where: str, shape: tuple[int, ...]) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.zeros(0)
    if (array.ndim != len(shape)
            or any(n not in (-1, m) for n, m in zip(shape, array.shape, strict=True))
            or not np.all(np.isfinite(array))):
        wanted = " x ".join("m" if n == -1 else str(n) for n in shape)
        raise ValueError(f"plan {where} must be {wanted} finite numbers, got {value!r}"[:200])
    return array


def _limits(robot: dict[str, Any], dof: int) -> MotionLimits:
    limits = robot.get("limits")
    if not isinstance(limits, dict):
        raise ValueError("plan has no robot.limits (written before export existed); plan it "
                         "again with `vprobot plan --out`")
    return MotionLimits(*(_array(limits.get(key), f"robot.limits.{key}", (dof,))
                          for key in ("velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3")))


def plan_motion(document: dict[str, Any]) -> PlanMotion:
    """The timed cycle of a robot plan: approach, moves between views, return.

    A view with `waypoints` is a move and an acquisition at its last corner; views where the
    robot stayed (unreachable requests, null `waypoints`) are neither.

    Raises:
        ValueError: For a free-flying plan (no robot program), a plan without the moves'
            corners (written before export existed), without an acquisition or without a way
            back to the start, with a view's joints not where its move ends, or with malformed
            fields.
    """
    if document.get("carrier", "robot") != "robot":
        raise ValueError(f"the plan's carrier is {document.get('carrier')!r}: a free-flying "
                         f"sensor has no robot program to export or check")
    robot = document.get("robot")
    if not isinstance(robot, dict) or not isinstance(robot.get("joint_names"), list):
        raise ValueError("plan has no robot.joint_names")
    names = tuple(str(name) for name in robot["joint_names"])
    limits = _limits(robot, len(names))
    if "return" not in document:
        raise ValueError("plan has no return or waypoints (written before export existed); "
                         "plan it again with `vprobot plan --out`")
    moves, stops = [], []
    for index, view in enumerate(document["views"]):
        if view.get("waypoints") is None:
            continue
        where = f"views[{index}]"
        corners = _array(view["waypoints"], f"{where}.waypoints", (-1, len(names)))
        if view.get("joints") is not None and not np.array_equal(view["joints"], corners[-1]):
            raise ValueError(f"plan {where}.joints are not the last of its waypoints")
        moves.append(corners)
        stops.append(ViewStop(index, corners[-1],
                              _array(view.get("position"), f"{where}.position", (3,)),
                              _array(view.get("quaternion"), f"{where}.quaternion", (4,))))
    back = document["return"]
    if not stops or not isinstance(back, dict) or back.get("waypoints") is None:
        why = back.get("reason") if isinstance(back, dict) else None
        raise ValueError(f"the plan's cycle is not closed ({why or 'no view acquired'}): "
                         f"nothing to export or check")
    moves.append(_array(back["waypoints"], "return.waypoints", (-1, len(names))))
    sensor = document.get("sensor")
    if not isinstance(sensor, dict) or "acquisition_time_s" not in sensor:
        raise ValueError("plan has no sensor.acquisition_time_s")
    acquisition_time_s = float(sensor["acquisition_time_s"])
    timed = time_plan(moves, limits, acquisition_time_s, names)
    return PlanMotion(str(robot.get("name")), limits, tuple(moves), tuple(stops),
                      acquisition_time_s, timed)


def require_ur(motion: PlanMotion) -> None:
    """Refuse a robot that does not run URScript.

    Raises:
        ValueError: If the robot is not a Universal Robots arm.
    """
    if not UR_ROBOT.fullmatch(motion.robot):
        raise ValueError(f"URScript runs on Universal Robots arms (ur5, ur10, ...); the plan's "
                         f"robot is {motion.robot!r}: export --format trajectory, csv or ros2")
