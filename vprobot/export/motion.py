"""A plan JSON's motion, timed: what every export format writes and the replay check replays.

Everything comes from the plan alone (docs/plan-format.md): the corners of every move, the
return, the robot's limits and the sensor's acquisition time, and for the programs the robot's
base, the sensor mount, the payload and the program's I/O (the plan's `cell` block); the time
law is `vprobot.kinematics.trajectory.time_plan` (docs/motion.md#the-time-law), the one that
gave the plan's `cycle_time`.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from vprobot.config import SensorConfig
from vprobot.config.cell import ProgramConfig
from vprobot.files.schema import ConfigError, brief, from_mapping
from vprobot.geometry.poses import Pose, quat_to_matrix
from vprobot.kinematics.trajectory import TimedPlan, time_plan
from vprobot.plan import plan_array, plan_carrier, plan_number, plan_quaternion
from vprobot.robots.description import MotionLimits

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
class ProgramCell:
    """What a robot program needs of the cell beyond the motion.

    Attributes:
        base: The robot's base body in the world (the plan's `robot.base_position`,
            `base_quaternion`).
        mount: The sensor frame, the program's TCP, in the flange frame (`robot.sensor_mount`).
        payload_kg: The sensor's mass (`cell.payload_kg`).
        payload_center: Where its centre of gravity is taken to be: the housing's centre
            (`cell.housing`) in the flange frame (m), an estimate.
        io: How the program triggers the sensor and waits for it, and the ROS 2 tolerances
            (`cell.program`).
        from_plan: False for a plan written before the `cell` block existed, whose payload and
            I/O are then the defaults (`SensorConfig`, `ProgramConfig`).
    """

    base: Pose
    mount: Pose
    payload_kg: float
    payload_center: np.ndarray
    io: ProgramConfig
    from_plan: bool


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
        cell: What the programs need of the cell.
    """

    robot: str
    limits: MotionLimits
    moves: tuple[np.ndarray, ...]
    stops: tuple[ViewStop, ...]
    acquisition_time_s: float
    timed: TimedPlan
    cell: ProgramCell

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


def _pose(block: Any, position_key: str, quaternion_key: str, where: str) -> Pose:
    position = block.get(position_key) if isinstance(block, dict) else None
    return Pose(plan_array(position, f"{where}.{position_key}", (3,)),
                quat_to_matrix(plan_quaternion(block, quaternion_key, where)))


def program_cell(document: dict[str, Any]) -> ProgramCell:
    """The cell as the programs need it, from the plan's `robot` and `cell` blocks; a plan
    without a `cell` block (written before it existed) takes the default sensor's payload and
    the default I/O, which are the cell it was planned in.

    Raises:
        ValueError: Naming a malformed field.
    """
    robot = document["robot"]
    base = _pose(robot, "base_position", "base_quaternion", "robot")
    mount = _pose(robot.get("sensor_mount"), "position", "quaternion", "robot.sensor_mount")
    cell = document.get("cell")
    if cell is None:
        sensor = SensorConfig()
        payload_kg, housing, io = (sensor.mass_kg, np.array(sensor.housing.position_m),
                                   ProgramConfig())
    else:
        if not isinstance(cell, dict) or not isinstance(cell.get("program"), dict):
            raise ValueError(f"plan cell must be an object with a program object, got "
                             f"{brief(cell)}")
        payload_kg = plan_number(cell.get("payload_kg"), "cell.payload_kg")
        block = cell.get("housing")
        housing = plan_array(block.get("position_m") if isinstance(block, dict) else None,
                             "cell.housing.position_m", (3,))
        try:
            io = from_mapping(ProgramConfig, cell["program"], "cell.program")
        except ConfigError as error:
            raise ValueError(f"plan {error}") from None
    return ProgramCell(base, mount, payload_kg, mount.position + mount.rotation @ housing, io,
                       from_plan=cell is not None)


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
            fields (the `cell` block's too: `program_cell`).
    """
    carrier = plan_carrier(document)
    if carrier != "robot":
        raise ValueError(f"the plan's carrier is {carrier!r}: a free-flying "
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
    return PlanMotion(name, limits, tuple(moves), tuple(stops), acquisition_time_s, timed,
                      program_cell(document))


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
