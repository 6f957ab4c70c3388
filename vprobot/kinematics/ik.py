"""Inverse kinematics of the sensor frame with mink, one attempt from one start configuration."""

from __future__ import annotations

import dataclasses
import math

import mink
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.config import KinematicsConfig
from vprobot.geometry.poses import Pose, axis_angle, rotation_angle

STALL_WINDOW = 8
"""An attempt stops when its error has not dropped by STALL_FACTOR within this many iterations."""
STALL_FACTOR = 0.95


@dataclasses.dataclass(frozen=True)
class SensorTarget:
    """A requested sensor pose, as the IK demands it: which pose, and which of its degrees of
    freedom count (docs/episodes-and-carriers.md#views-requests-and-records).

    In the world, except from `ActionMapping.view`, which gives it in the object-centred frame
    (a look-at view looking at the origin) before `ActionMapping.target` places it. A planner
    wraps it in a `ViewRequest`, which may add a configuration known to reach it.

    Attributes:
        pose: Position and orientation of the sensor frame (+z viewing direction).
        roll_free: Leave the rotation about the viewing axis to the IK (only the position and
            the viewing direction are demanded).
        look_at_point: For look-at targets, the point the viewing axis must pass through.
    """

    pose: Pose
    roll_free: bool
    look_at_point: np.ndarray | None = None

    @classmethod
    def look_at(cls, position: np.ndarray, look_at_point: np.ndarray) -> SensorTarget:
        """Sensor at `position` looking at `look_at_point`, roll left free.

        Raises:
            ValueError: If an input is not a finite 3-vector or both points coincide.
        """
        pose = Pose.look_at(position, look_at_point)
        return cls(pose, roll_free=True, look_at_point=np.asarray(look_at_point, dtype=float))

    def orientation_tolerance(self, tolerance_rad: float, position_tolerance_m: float) -> float:
        """Angular tolerance; for look-at targets tight enough that the viewing axis misses the
        point by at most `position_tolerance_m`."""
        if self.look_at_point is None:
            return tolerance_rad
        distance = float(np.linalg.norm(self.look_at_point - self.pose.position))
        return min(tolerance_rad, float(np.arctan(position_tolerance_m / distance)))

    @classmethod
    def full_pose(cls, position: np.ndarray, quat_wxyz: np.ndarray) -> SensorTarget:
        """Sensor at `position` with orientation `quat_wxyz`, roll included."""
        return cls(Pose.from_quat(position, quat_wxyz), roll_free=False)


@dataclasses.dataclass(frozen=True)
class IKAttempt:
    """Outcome of one IK attempt.

    Attributes:
        q: Final joint configuration (within the joint limits).
        converged: Both residuals are within the tolerances.
        iterations: Iterations used.
        position_error_m: Distance of the sensor from the target position.
        orientation_error_rad: Angle between the viewing axis and the direction to the look-at
            point (look-at), between the viewing axes (roll free) or of the whole relative
            rotation (roll fixed).
        at_joint_limit: Some joint ended on its limit.
    """

    q: np.ndarray
    converged: bool
    iterations: int
    position_error_m: float
    orientation_error_rad: float
    at_joint_limit: bool


def residuals(pose: Pose, target: SensorTarget) -> tuple[float, float]:
    """Position (m) and orientation (rad) errors of `pose` against `target`."""
    position_error = math.dist(pose.position, target.pose.position)
    if target.look_at_point is not None:
        direction = target.look_at_point - pose.position
        return position_error, axis_angle(pose.view_axis, direction / math.hypot(*direction))
    if target.roll_free:
        return position_error, axis_angle(pose.view_axis, target.pose.view_axis)
    return position_error, rotation_angle(pose.rotation, target.pose.rotation)


def wrap_toward(q: np.ndarray, reference: np.ndarray, lower: np.ndarray,
                upper: np.ndarray) -> np.ndarray:
    """Shift joints by whole turns toward `reference` where the limits allow it.

    Joints with a range over 2 pi reach the same pose at q and q +- 2 pi; the one closest to the
    reference is the shorter move.
    """
    turns = np.round((reference - q) / (2.0 * np.pi))
    shifted = q + turns * 2.0 * np.pi
    return np.where((shifted >= lower) & (shifted <= upper), shifted, q)


class IKSolver:
    """Damped least-squares IK on mink's FrameTask error and Jacobian.

    Each iteration takes the Levenberg-Marquardt step of mink's frame task (its body-frame twist
    error and Jacobian), scaled down so that no joint moves more than `max_step_rad`, and keeps
    the joints inside their limits by projection. mink's `solve_ik` would pose the same step as
    a QP; for a 6-joint arm with box limits the projection is equivalent in practice and about
    three times faster, which matters because IK runs in every environment step.

    Args:
        cell: The compiled cell (only the robot's kinematic tree is used).
        settings: Tolerances, iteration budget, damping and step size.
    """

    def __init__(self, cell: Cell, settings: KinematicsConfig):
        self.cell = cell
        self.settings = settings
        self.configuration = mink.Configuration(cell.model)
        self.task = mink.FrameTask("sensor", "site", position_cost=1.0, orientation_cost=1.0)
        self.position_tolerance = settings.position_tolerance_m
        self.orientation_tolerance = np.deg2rad(settings.orientation_tolerance_deg)
        self._eye = np.eye(cell.joints.dof)

    def _current_pose(self) -> Pose:
        data = self.configuration.data
        site = self.cell.sensor_site_id
        return Pose(data.site_xpos[site], data.site_xmat[site].reshape(3, 3))

    def solve(self, target: SensorTarget, q_start: np.ndarray) -> IKAttempt:
        """Run one attempt from `q_start` (the warm start decides which branch is found).

        Args:
            target: The requested sensor pose.
            q_start: Start configuration, within the joint limits.

        Returns:
            The attempt; `q` is wrapped by whole turns toward `q_start`.
        """
        joints = self.cell.joints
        q_start = np.clip(joints.check(q_start, "start configuration"), joints.lower, joints.upper)
        # A zero cost on the body z rotation leaves the roll about the optical axis free:
        # zero x, y rotation error then means the viewing axes coincide.
        self.task.set_orientation_cost([1.0, 1.0, 0.0] if target.roll_free else 1.0)
        self.task.set_target(
            mink.SE3.from_rotation_and_translation(
                mink.SO3.from_matrix(target.pose.rotation), target.pose.position
            )
        )
        orientation_tolerance = target.orientation_tolerance(self.orientation_tolerance,
                                                             self.position_tolerance)
        q = q_start.copy()
        self.configuration.update(q)
        best, best_iteration = np.inf, 0
        iteration = 0
        for iteration in range(self.settings.max_iterations + 1):
            position_error, orientation_error = residuals(self._current_pose(), target)
            if (position_error <= self.position_tolerance
                    and orientation_error <= orientation_tolerance):
                return self._attempt(q, q_start, True, iteration, position_error, orientation_error)
            error = (position_error / self.position_tolerance
                     + orientation_error / orientation_tolerance)
            if error < STALL_FACTOR * best:
                best, best_iteration = error, iteration
            elif (iteration - best_iteration >= STALL_WINDOW
                  or iteration == self.settings.max_iterations):
                break
            jacobian, weighted_error, mu = self.task.compute_qp_residual(self.configuration)
            hessian = jacobian.T @ jacobian + (self.settings.damping + mu) * self._eye
            step = np.linalg.solve(hessian, jacobian.T @ weighted_error)
            largest = np.max(np.abs(step))
            if largest > self.settings.max_step_rad:
                step *= self.settings.max_step_rad / largest
            q = np.clip(q + step, joints.lower, joints.upper)
            self.configuration.update(q)
        return self._attempt(q, q_start, False, iteration, position_error, orientation_error)

    def _attempt(self, q: np.ndarray, q_start: np.ndarray, converged: bool, iterations: int,
                 position_error: float, orientation_error: float) -> IKAttempt:
        joints = self.cell.joints
        at_limit = bool(((q <= joints.lower + 1e-9) | (q >= joints.upper - 1e-9)).any())
        if converged:
            q = wrap_toward(q, q_start, joints.lower, joints.upper)
        return IKAttempt(
            q=q.copy(),
            converged=converged,
            iterations=iterations,
            position_error_m=position_error,
            orientation_error_rad=orientation_error,
            at_joint_limit=at_limit,
        )


def random_configuration(rng: np.random.Generator, lower: np.ndarray,
                         upper: np.ndarray) -> np.ndarray:
    """A configuration drawn uniformly within the limits, each joint at most half a turn out."""
    return rng.uniform(np.maximum(lower, -np.pi), np.minimum(upper, np.pi))

