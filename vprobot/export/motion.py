"""A plan JSON's motion, timed: what every export format writes and the replay check replays.

Everything comes from the plan alone (docs/plan-format.md): the corners of every move, the
return, the robot's limits and the sensor's acquisition time; the time law is
`vprobot.kinematics.trajectory.time_plan` (docs/motion.md#the-time-law), the one that gave the
plan's `cycle_time`.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from vprobot.kinematics.trajectory import MotionLimits, TimedPlan, time_plan
from vprobot.render.replay import plan_array, plan_number, plan_quaternion
from vprobot.schema import brief

UR_ROBOT = re.compile(r"ur\d+e?", re.IGNORECASE)
"""Names of Universal Robots arms, the robots a URScript program runs on (ur5, ur10, ur10e...)."""
NAME_MAX_CHARS = 100
NAME = re.compile(rf"[A-Za-z0-9_][A-Za-z0-9_./-]{{0,{NAME_MAX_CHARS - 1}}}")
"""A robot or joint name a plan may give: no line break, quote, comma, bracket or space, so
that no format's syntax (URScript, YAML, CSV) can be opened by a name, comments included."""
MIN_LIMIT = 1e-3
"""Smallest velocity (rad/s), acceleration (rad/s^2) and jerk (rad/s^3) limit of a plan: a
joint at 1 mrad/s takes almost two hours for a turn, and below 1e-20 Ruckig finds no profile."""


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


def _limits(robot: dict[str, Any], dof: int) -> MotionLimits:
    limits = robot.get("limits")
    if not isinstance(limits, dict):
        raise ValueError("plan has no robot.limits (written before export existed); plan it "
                         "again with `vprobot plan --out`")
    arrays = []
    for key, unit in (("velocity_rad_s", "rad/s"), ("acceleration_rad_s2", "rad/s^2"),
                      ("jerk_rad_s3", "rad/s^3")):
        where = f"robot.limits.{key}"
        values = plan_array(limits.get(key), where, (dof,))
        if not np.all(values >= MIN_LIMIT):
            raise ValueError(f"plan {where} must be {dof} numbers >= {MIN_LIMIT:g} {unit}, got "
                             f"{brief(values.tolist())}")
        arrays.append(values)
    return MotionLimits(*arrays)


def check_name(name: Any, where: str) -> str:
    """`name` if it is a robot or joint name (`NAME`), else a ValueError naming the plan's
    field `where`: every export format writes names as they are, in comments too."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise ValueError(f"plan {where} must be a name of at most {NAME_MAX_CHARS} ASCII "
                         f"letters, digits, '_', '.', '/' or '-' (starting with a letter, digit or "
                         f"'_'), got {brief(name)}")
    return name


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
    name = check_name(robot.get("name"), "robot.name")
    names = tuple(check_name(joint, f"robot.joint_names[{index}]")
                  for index, joint in enumerate(robot["joint_names"]))
    limits = _limits(robot, len(names))
    if "return" not in document:
        raise ValueError("plan has no return or waypoints (written before export existed); "
                         "plan it again with `vprobot plan --out`")
    moves, stops = [], []
    for index, view in enumerate(document["views"]):
        where = f"views[{index}]"
        if not isinstance(view, dict):
            raise ValueError(f"plan {where} must be an object, got {brief(view)}")
        if view.get("waypoints") is None:
            continue
        corners = plan_array(view["waypoints"], f"{where}.waypoints", (-1, len(names)))
        if view.get("joints") is not None and not np.array_equal(view["joints"], corners[-1]):
            raise ValueError(f"plan {where}.joints are not the last of its waypoints")
        moves.append(corners)
        stops.append(ViewStop(index, corners[-1],
                              plan_array(view.get("position"), f"{where}.position", (3,)),
                              plan_quaternion(view, "quaternion", where)))
    back = document["return"]
    if not stops or not isinstance(back, dict) or back.get("waypoints") is None:
        why = back.get("reason") if isinstance(back, dict) else None
        raise ValueError(f"the plan's cycle is not closed ({why or 'no view acquired'}): "
                         f"nothing to export or check")
    moves.append(plan_array(back["waypoints"], "return.waypoints", (-1, len(names))))
    sensor = document.get("sensor")
    if not isinstance(sensor, dict) or "acquisition_time_s" not in sensor:
        raise ValueError("plan has no sensor.acquisition_time_s")
    acquisition_time_s = plan_number(sensor["acquisition_time_s"], "sensor.acquisition_time_s")
    timed = time_plan(moves, limits, acquisition_time_s, names)
    return PlanMotion(name, limits, tuple(moves), tuple(stops), acquisition_time_s, timed)


def require_robot(motion: PlanMotion, robot: str, joint_names: Sequence[str]) -> None:
    """Refuse a plan whose robot name or joint names are not those of the robot it names (its
    bundled model or robot folder): a plan edited by hand, or made for another robot.

    Raises:
        ValueError: Naming the plan's names and the robot's.
    """
    if motion.robot != robot:
        raise ValueError(f"plan robot.name {motion.robot!r} is not the name of the plan's robot, "
                         f"{robot!r}")
    if motion.joint_names != tuple(joint_names):
        raise ValueError(f"plan's joint names {list(motion.joint_names)} are not the robot's "
                         f"{list(joint_names)}")


def require_ur(motion: PlanMotion) -> None:
    """Refuse a robot that does not run URScript.

    Raises:
        ValueError: If the robot is not a Universal Robots arm.
    """
    if not UR_ROBOT.fullmatch(motion.robot):
        raise ValueError(f"URScript runs on Universal Robots arms (ur5, ur10, ...); the plan's "
                         f"robot is {motion.robot!r}: export --format trajectory, csv or ros2")
