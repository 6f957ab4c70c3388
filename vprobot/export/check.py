"""The replay check: a plan's exported trajectory replayed in its MuJoCo cell, held to the robot's
own limits by finite differences of the samples, not by the time law's word
(docs/motion.md#replay-check).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.cell.check import Clearance, clearances
from vprobot.cell.scene import Cell, JointSpace
from vprobot.config import Config
from vprobot.export import CHECK_DT_S
from vprobot.export.motion import PlanMotion, plan_motion, require_robot
from vprobot.files.schema import brief
from vprobot.geometry.poses import quat_to_matrix, rotation_angle
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.forward import ForwardKinematics
from vprobot.kinematics.motion_planner import densify
from vprobot.kinematics.trajectory import Trajectory
from vprobot.plan import plan_array, plan_field, plan_number, plan_object, read_plan
from vprobot.robots.description import MotionLimits

POSITION_TOLERANCE_M = 1e-4
"""Largest distance of the replayed sensor from the plan's view at an acquisition (0.1 mm)."""
ANGLE_TOLERANCE_DEG = 0.01
"""Largest angle between the replayed sensor frame and the plan's view at an acquisition."""
LIMIT_SLACK = 1e-6
"""Relative slack on the velocity, acceleration and jerk limits. The k-th divided difference
of the samples times k! is a weighted mean of the k-th derivative between them (the positions
are twice continuously differentiable and the jerk piecewise constant), so it stays within a
limit the trajectory holds; the slack, and the rounding bound of `rounding_bound`, absorb only
floating-point error."""
DERIVATIVES = ("velocity", "acceleration", "jerk")


@dataclasses.dataclass(frozen=True)
class PlanCheck:
    """What the replay found.

    Attributes:
        samples: Replayed samples.
        dt_s: The replay step.
        cycle_s: The cycle time of the replayed trajectory.
        dense_configurations: Configurations checked along the moves' straight segments, at the
            path planner's resolution (`kinematics.path_max_joint_step_rad`).
        peak_share: Per derivative, the largest share of a joint's limit used (1 = at it).
        pose_error_mm: Largest sensor position error at an acquisition (mm).
        pose_error_deg: Largest sensor orientation error at an acquisition (deg).
        clearances: Per object of the cell, the least distance from the robot (sensor housing
            included) over the samples and the dense configurations, and its margin.
        failures: What does not hold, one line each; empty when the plan passes.
    """

    samples: int
    dt_s: float
    cycle_s: float
    dense_configurations: int
    peak_share: dict[str, float]
    pose_error_mm: float
    pose_error_deg: float
    clearances: tuple[Clearance, ...]
    failures: tuple[str, ...]

    @property
    def holds(self) -> bool:
        return not self.failures

    def report(self) -> str:
        """A short report: the figures, then each failure."""
        shares = ", ".join(f"{name} {self.peak_share[name]:.0%}" for name in DERIVATIVES)
        lines = [f"replayed {self.samples} samples at {self.dt_s * 1e3:g} ms over a "
                 f"{self.cycle_s:.3f} s cycle, {self.dense_configurations} configurations along "
                 f"the paths",
                 f"  peak share of the limits: {shares}",
                 f"  sensor at the acquisitions: within {self.pose_error_mm:.2g} mm / "
                 f"{self.pose_error_deg:.2g} deg of the plan's views",
                 "  least clearance from the robot and its sensor housing:",
                 *(f"    {item.name}: {item.distance_m * 1e3:.1f} mm, margin "
                   f"{item.margin_m * 1e3:g} mm, {'ok' if item.holds else 'FAILS'}"
                   for item in self.clearances),
                 "  check holds" if self.holds else f"  check FAILED ({len(self.failures)}):",
                 *(f"  - {failure}" for failure in self.failures)]
        return "\n".join(lines)


def divided_differences(times: np.ndarray, values: np.ndarray, order: int) -> np.ndarray:
    """`order`! times the divided differences of `values` (n, dof) over each `order` + 1
    consecutive `times`: the finite-difference estimate of the `order`-th derivative."""
    for k in range(1, order + 1):
        values = (values[1:] - values[:-1]) / (times[k:] - times[:-k])[:, None]
    return values * math.factorial(order)


def rounding_bound(positions: np.ndarray, step: float, order: int) -> float:
    """How far floating-point rounding of the positions (a few ulps) can move an `order`-th
    divided difference over samples at least `step` apart."""
    # Finite positions only: a NaN one is a failure of its own samples, not of every sample.
    largest = np.abs(positions[np.isfinite(positions)]).max(initial=0.0)
    return 2.0**order * 16 * np.finfo(float).eps * (largest + 1.0) / step**order


def limit_failures(samples: Trajectory, limits: MotionLimits
                   ) -> tuple[dict[str, float], list[str]]:
    """Velocity, acceleration and jerk by finite differences of the sampled positions against
    the limits: the peak share of a limit per derivative, and a line per derivative exceeded
    (its first sample, time and joint)."""
    step = float(np.diff(samples.times).min())
    shares, failures = {}, []
    for order, (name, limit) in enumerate(zip(
            DERIVATIVES, (limits.velocity, limits.acceleration, limits.jerk), strict=True), 1):
        estimate = np.abs(divided_differences(samples.times, samples.positions, order))
        allowed = limit * (1 + LIMIT_SLACK) + rounding_bound(samples.positions, step, order)
        shares[name] = float((estimate / limit).max())
        over = np.argwhere(~(estimate <= allowed))  # NaN fails too
        if len(over):
            row, joint = over[0]
            failures.append(
                f"{name} limit exceeded at t={samples.times[row]:.4f} s (sample {row}): "
                f"{samples.joint_names[joint]} {estimate[row, joint]:.4g} > "
                f"{limit[joint]:.4g} ({len(over)} samples x joints over)")
    return shares, failures


def declared_limit_failures(declared: MotionLimits, robot: MotionLimits,
                            joint_names: tuple[str, ...]) -> list[str]:
    """A line per limit the plan was timed under (`robot.limits`) above the robot's: the time
    law holds the plan's limits exactly, so this finds a plan timed beyond the robot's at any
    replay step, where divided differences over coarse samples average a short peak away."""
    failures = []
    for name, key, plan, own in zip(
            DERIVATIVES, ("velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3"),
            (declared.velocity, declared.acceleration, declared.jerk),
            (robot.velocity, robot.acceleration, robot.jerk), strict=True):
        over = np.flatnonzero(plan > own * (1 + LIMIT_SLACK))
        if len(over):
            joint = over[0]
            failures.append(f"{name} limit: the plan was timed under robot.limits.{key} above "
                            f"the robot's: {joint_names[joint]} {plan[joint]:.4g} > "
                            f"{own[joint]:.4g} ({len(over)} joints over)")
    return failures


def joint_range_failures(document: dict[str, Any], joints: JointSpace) -> list[str]:
    """A line when the joint limits the plan states it was planned within
    (`cell.joint_limits_rad`) differ from the rebuilt cell's (its robot's less the cell's
    joint-limit margin), which the samples are held to; none for a plan without a cell block."""
    block = document.get("cell")
    if block is None:
        return []
    limits = plan_field(block, "joint_limits_rad", "cell")
    stated = [plan_array(plan_field(limits, key, "cell.joint_limits_rad"),
                         f"cell.joint_limits_rad.{key}", (joints.dof,))
              for key in ("lower", "upper")]
    if all(np.allclose(plan, own, rtol=0.0, atol=1e-9)
           for plan, own in zip(stated, (joints.lower, joints.upper), strict=True)):
        return []
    return [f"joint limits: the plan states cell.joint_limits_rad {np.round(stated, 4).tolist()}"
            f", the cell rebuilt from its settings has {np.round(joints.lower, 4).tolist()} .. "
            f"{np.round(joints.upper, 4).tolist()} rad"]


def _stated_cycle_s(document: dict[str, Any]) -> float | None:
    """The plan's `cycle_time.total_s`, None when the plan states no cycle time."""
    cycle = document.get("cycle_time")
    if cycle is None:
        return None
    if not isinstance(cycle, dict) or "total_s" not in cycle:
        raise ValueError(f"plan cycle_time must be null or an object with total_s, got "
                         f"{brief(cycle)}")
    return plan_number(cycle["total_s"], "cycle_time.total_s")


def _cell(config: Config, document: dict, plan_path: Path) -> tuple[Cell, np.ndarray]:
    """The plan's cell (robot, base, mount, the object where the plan put it) and the object's
    rotation, as `vprobot render --plan` rebuilds them."""
    cell_config, mesh, rotation = plan_object(config, document, plan_path)
    return Cell(cell_config, mesh.mesh), rotation


def _collision_failures(cell: Cell, rotation: np.ndarray, motion: PlanMotion,
                        samples: Trajectory, step_rad: float
                        ) -> tuple[int, list[Clearance], list[str]]:
    """Collisions (closer than a margin) at every sample and along every straight segment at
    `step_rad`, and the least clearance to each object over all of them."""
    checker = CollisionChecker(cell, rotation, planning=False)
    failures = []
    hit = checker.first_collision(samples.positions)
    if hit is not None:
        failures.append(f"collision at t={samples.times[hit]:.4f} s (sample {hit}): "
                        f"{_pairs(checker, samples.positions[hit])}")
    paths = [densify(move, step_rad) for move in motion.moves]
    for index, path in enumerate(paths):
        hit = checker.first_collision(path)
        if hit is not None:
            failures.append(f"collision on move {index} ({_move_name(index, motion)}) at "
                            f"{np.round(path[hit], 4).tolist()}: "
                            f"{_pairs(checker, path[hit])}")
    data = cell.make_data()
    cell.place_object(data, rotation)
    least = clearances(cell, data, np.concatenate([samples.positions, *paths]))
    failures += [f"clearance: the robot comes {item.distance_m * 1e3:.1f} mm from {item.name}, "
                 f"within its margin of {item.margin_m * 1e3:g} mm (cell.safety)"
                 for item in least if not item.holds]
    return sum(len(path) for path in paths), least, failures


def _pairs(checker: CollisionChecker, q: np.ndarray) -> str:
    return ", ".join(sorted({f"{a}-{b}" for a, b in checker.colliding_pairs(q)}))


def _move_name(index: int, motion: PlanMotion) -> str:
    if index == len(motion.stops):
        return "the return"
    return "the approach" if index == 0 else f"to view {motion.stops[index].view}"


def check_plan(config: Config, plan_path: str | Path, dt: float = CHECK_DT_S) -> PlanCheck:
    """Replay a plan's timed trajectory in its cell and check it.

    At every sample (every multiple of `dt`, every corner, every start and end of an
    acquisition) and along every move's segments at the path planner's resolution: no
    collision; at every sample: within the joint limits; velocity, acceleration and jerk by
    divided differences of the sampled positions within the robot's limits (its `robot.yaml`,
    not the plan's copy), and the limits the plan was timed under within them too; the plan's
    robot and joint names the robot's; at each acquisition the sensor (forward kinematics of
    the replayed configuration) within 0.1 mm / 0.01 deg of the plan's view, and the cycle
    time the plan states.

    Args:
        config: Settings the plan does not fix (the path resolution).
        plan_path: The plan JSON (docs/plan-format.md).
        dt: The replay step (s).

    Raises:
        ValueError: For an unreadable plan, one without a robot cycle (`plan_motion`), one
            whose robot or joint names are not its robot's, a malformed `cycle_time`, a
            missing mesh or robot, or a step that is not > 0 or takes more than
            `vprobot.kinematics.trajectory.MAX_SAMPLES` samples.
    """
    plan_path = Path(plan_path)
    document = read_plan(plan_path)
    motion = plan_motion(document)
    stated = _stated_cycle_s(document)
    samples = motion.timed.sample(dt)
    cell, rotation = _cell(config, document, plan_path)
    require_robot(motion, cell.robot.name, cell.joints.names)
    dense, least, failures = _collision_failures(
        cell, rotation, motion, samples, cell.config.kinematics.path_max_joint_step_rad)
    joints = cell.joints
    failures += joint_range_failures(document, joints)
    outside = np.argwhere(~((samples.positions >= joints.lower - 1e-9)
                            & (samples.positions <= joints.upper + 1e-9)))  # NaN fails too
    if len(outside):
        row, joint = outside[0]
        failures.append(f"joint limit exceeded at t={samples.times[row]:.4f} s (sample {row}): "
                        f"{joints.names[joint]} {samples.positions[row, joint]:.4f} outside "
                        f"{joints.lower[joint]:.4f} .. {joints.upper[joint]:.4f} rad")
    robot_limits = cell.motion_limits
    failures += declared_limit_failures(motion.limits, robot_limits, motion.joint_names)
    shares, exceeded = limit_failures(samples, robot_limits)
    failures += exceeded
    position_mm, angle_deg = 0.0, 0.0
    forward = ForwardKinematics(cell)
    for stop, acquisition in zip(motion.stops, motion.timed.acquisitions, strict=True):
        at = motion.timed.states([acquisition.start_s, acquisition.end_s])[0]
        for q in at:
            pose = forward.sensor_pose(q)
            distance = float(np.linalg.norm(pose.position - stop.position)) * 1e3
            angle = math.degrees(rotation_angle(pose.rotation, quat_to_matrix(stop.quaternion)))
            position_mm, angle_deg = max(position_mm, distance), max(angle_deg, angle)
            if not (distance <= POSITION_TOLERANCE_M * 1e3 and angle <= ANGLE_TOLERANCE_DEG):
                failures.append(f"sensor pose at view {stop.view} (t={acquisition.start_s:.4f}"
                                f" s) is {distance:.4f} mm / {angle:.4f} deg from the plan's")
                break
    if stated is None or not abs(stated - motion.timed.cycle.total_s) <= 1e-6:
        failures.append(f"cycle time {motion.timed.cycle.total_s:.6f} s replayed, the plan "
                        f"states {stated}")
    return PlanCheck(len(samples.times), dt, motion.timed.cycle.total_s, dense, shares,
                     position_mm, angle_deg, tuple(least), tuple(failures))
