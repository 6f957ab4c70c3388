"""The robot arm of a cell: forward kinematics, reachability of views, collisions, travel."""

from __future__ import annotations

import dataclasses
import functools
import itertools
from collections.abc import Callable
from typing import Literal

import mujoco
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.config import KinematicsConfig
from vprobot.geometry.poses import Pose
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.forward import ForwardKinematics
from vprobot.kinematics.ik import (
    IKAttempt,
    IKSolver,
    SensorTarget,
    random_configuration,
    residuals,
)
from vprobot.kinematics.motion_planner import MotionPlan, MotionPlanner
from vprobot.kinematics.path import joint_path
from vprobot.kinematics.trajectory import TimedMove, time_move
from vprobot.kinematics.travel import (
    TravelCost,
    joint_path_length,
    joint_time,
    paper_travel,
    polyline_length,
)
from vprobot.robots.description import GEOM_GROUP_ROBOT

FailureReason = Literal["out_of_reach", "did_not_converge", "joint_limits", "collision",
                        "path_not_found"]
ROLL_TURNS = (np.pi / 2, -np.pi / 2, np.pi)
MAX_ROLL_VARIANTS = 2
"""Converged but colliding attempts whose roll variants are tried (each adds ROLL_TURNS)."""

MAX_SEED_DRAWS = 1000
"""Random configurations drawn at most for the restart seeds. A fitting object leaves over 10 %
of them collision-free (about a third for the bundled motors), so 1000 draws (about 35 ms of
collision checks) give far more than the configured restarts; an object that blocks the cell
gets fewer seeds instead of an endless search."""

FAILURE_REASONS: tuple[FailureReason, ...] = (
    "did_not_converge", "joint_limits", "collision", "path_not_found"
)
"""The stages an IK attempt fails at, in order; a failure carries the furthest one reached."""
OUT_OF_REACH: FailureReason = "out_of_reach"
"""The failure of a target farther from the shoulder than the arm reaches: no attempt is made."""
UNSOLVED: tuple[FailureReason, ...] = (OUT_OF_REACH, "did_not_converge", "joint_limits")
"""The failures without a valid IK solution (the others found one that collides)."""


@dataclasses.dataclass(frozen=True)
class ReachResult:
    """Whether and how the robot reaches a requested sensor pose from its current configuration.

    Attributes:
        reachable: IK converged within the joint limits to a collision-free configuration that a
            collision-free joint-space path (the straight line, or a planned one) connects to
            the start.
        q: The configuration reached; for a failure, the best attempt's final configuration
            (never to be executed).
        reason: None on success; `out_of_reach` for a target beyond the arm's reach (no
            attempt made); otherwise the furthest stage a failing attempt got to:
            `did_not_converge`, `joint_limits`, `collision` (at the goal) or `path_not_found`
            (no collision-free path found within the planning time).
        iterations: IK iterations over all attempts.
        attempts: IK attempts made (1 + restarts used; 0 out of reach).
        position_error_m: Residual position error of the reported `q`.
        orientation_error_deg: Residual orientation error of the reported `q`.
        motion: The collision-free move from the start on success, else None.
    """

    reachable: bool
    q: np.ndarray
    reason: FailureReason | None
    iterations: int
    attempts: int
    position_error_m: float
    orientation_error_deg: float
    motion: MotionPlan | None = None

    @property
    def path(self) -> np.ndarray | None:
        """The move's sampled joint-space path (n, dof) on success, else None."""
        return None if self.motion is None else self.motion.path


class RobotArm:
    """Kinematics of the cell's robot: FK, IK with restarts, collision and path checks, travel.

    Collision checks run on a `CollisionChecker`, which holds the object placement they check
    against: `collisions` (the object upright) unless a call passes the episode's own.

    Args:
        cell: The compiled cell.
        settings: IK and path settings; the cell's config when omitted.
    """

    def __init__(self, cell: Cell, settings: KinematicsConfig | None = None):
        self.cell = cell
        self.settings = settings if settings is not None else cell.config.kinematics
        self.joints = cell.joints
        self.forward = ForwardKinematics(cell)
        self.collisions = CollisionChecker(cell)
        self.limits = cell.motion_limits
        self.ik = IKSolver(cell, self.settings)
        self.reach_radius_m = self._reach_radius()
        # The pan joint's body frame lies on the pan axis, whatever the other joints do.
        self.shoulder_position = self.forward.body_position(cell.pan_body_id, self.joints.start)
        self._pan_frame = self._pan_axis_frame()
        self.restart_seeds = self._restart_seeds()
        self._seed_azimuths = np.array([self._azimuth(self.fk(q).position)
                                        for q in self.restart_seeds])

    def _restart_seeds(self) -> list[np.ndarray]:
        """Home first, then collision-free random configurations from the configured seed.

        At most `MAX_SEED_DRAWS` random configurations are drawn: in a cell whose object blocks
        (nearly) every configuration there are fewer seeds, down to home alone, rather than an
        endless search.
        """
        rng = np.random.default_rng(self.settings.seed)
        seeds = [self.joints.start.copy()]
        for _ in range(MAX_SEED_DRAWS):
            if len(seeds) >= self.settings.restarts:
                break
            q = random_configuration(rng, self.joints.lower, self.joints.upper)
            if not self.collisions.in_collision(q):
                seeds.append(q)
        return seeds[: self.settings.restarts]

    def _azimuth(self, point: np.ndarray) -> float:
        """Angle of `point` about the pan joint's axis."""
        local = self._pan_frame.T @ (point - self.shoulder_position)
        return float(np.arctan2(local[1], local[0]))

    def _pan_axis_frame(self) -> np.ndarray:
        """A rotation whose z axis is the pan joint's axis in the world (positive turn sense).

        The pan joint is the chain's first, so its axis does not depend on the configuration.
        """
        data = self.forward.data
        joint = self.cell.model.body_jntadr[self.cell.pan_body_id]
        axis = data.xaxis[joint] / np.linalg.norm(data.xaxis[joint])
        helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
        x = np.cross(helper, axis)
        x /= np.linalg.norm(x)
        return np.column_stack([x, np.cross(axis, x), axis])

    def _aimed_seeds(self, target_position: np.ndarray) -> np.ndarray:
        """The restart seeds turned about the pan joint so that each faces the target."""
        seeds = np.array(self.restart_seeds).reshape(-1, self.joints.dof)
        turn = self._azimuth(target_position) - self._seed_azimuths
        seeds[:, self.cell.pan_index] += np.angle(np.exp(1j * turn))
        return np.clip(seeds, self.joints.lower, self.joints.upper)

    def _reach_radius(self) -> float:
        """Upper bound of the sensor's distance from the shoulder: the sum of the link offsets."""
        model = self.cell.model
        body = self.cell.sensor_body_id
        radius = float(np.linalg.norm(model.site_pos[self.cell.sensor_site_id]))
        while body != self.cell.pan_body_id:
            radius += float(np.linalg.norm(model.body_pos[body]))
            body = model.body_parentid[body]
        return radius

    def fk(self, q: np.ndarray) -> Pose:
        """Sensor pose in the world at configuration `q`."""
        return self.forward.sensor_pose(q)

    @functools.cached_property
    def _sight_data(self) -> mujoco.MjData:
        return self.cell.make_data()

    def hides(self, q: np.ndarray, points: np.ndarray) -> bool:
        """Whether the robot at `q` stands between its sensor and any of `points` (world).

        Only the robot's own geometry is cast against, which a cell knows (a self filter): a
        view the arm would hide can be told before it is taken.
        """
        model, data = self.cell.model, self._sight_data
        data.qpos[:] = self.joints.check(q, "q")
        mujoco.mj_kinematics(model, data)
        origin = self.fk(q).position
        groups = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
        groups[GEOM_GROUP_ROBOT] = 1
        geom = np.zeros(1, dtype=np.int32)
        for point in np.atleast_2d(points):
            offset = point - origin
            distance = float(np.linalg.norm(offset))
            hit = mujoco.mj_ray(model, data, origin, offset / distance, groups, 1,
                                self.cell.sensor_body_id, geom)
            if 0.0 <= hit < distance:
                return True
        return False

    def path(self, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
        """The sampled straight joint-space line between two configurations."""
        return joint_path(self.joints.check(q_from, "q_from"), self.joints.check(q_to, "q_to"),
                          self.settings.path_max_joint_step_rad)

    def plan(self, q_from: np.ndarray, q_to: np.ndarray,
             collisions: CollisionChecker | None = None) -> MotionPlan | None:
        """A collision-free move between two configurations (the straight line when free, else
        planned per `settings.path_planner`), or None when none was found.

        Args:
            q_from: Start configuration.
            q_to: Goal configuration.
            collisions: The checker holding the episode's object placement; `self.collisions`
                (object upright) when omitted.
        """
        collisions = collisions if collisions is not None else self.collisions
        return MotionPlanner(collisions, self.joints, self.settings).plan(q_from, q_to)

    def follow(self, waypoints: np.ndarray,
               collisions: CollisionChecker | None = None) -> MotionPlan | None:
        """The move along given corners, checked as `plan` checks its own, or None where it
        collides or leaves the limits (`MotionPlanner.follow`)."""
        collisions = collisions if collisions is not None else self.collisions
        return MotionPlanner(collisions, self.joints, self.settings).follow(waypoints)

    def reach(self, target: SensorTarget, q_from: np.ndarray,
              collisions: CollisionChecker | None = None,
              restarts: int | None = None,
              plan: Callable[[np.ndarray, np.ndarray], MotionPlan | None] | None = None
              ) -> ReachResult:
        """Find a feasible configuration for `target`, starting the IK from `q_from`.

        The first attempt is warm-started from `q_from`, so the nearest branch (shortest travel)
        wins; only if it fails are the restart seeds tried, up to `restarts`. For roll-free
        targets, an attempt that converges into a collision is also retried with the sensor
        turned about its axis (the first MAX_ROLL_VARIANTS such attempts).

        Args:
            target: The requested sensor pose.
            q_from: The configuration the robot is in.
            collisions: The checker holding the episode's object placement; `self.collisions`
                (object upright) when omitted.
            restarts: Restart seeds to try at most; `settings.restarts` when omitted.
            plan: Plans the move to a solution, as `plan` does with `collisions` (its
                default): an episode's keeps the moves it planned.

        Raises:
            ValueError: If `q_from` is not a finite configuration of the right size.
        """
        q_from = self.joints.check(q_from, "q_from")
        collisions = collisions if collisions is not None else self.collisions
        move = plan if plan is not None else functools.partial(self.plan, collisions=collisions)
        restarts = self.settings.restarts if restarts is None else min(restarts,
                                                                       self.settings.restarts)
        distance = np.linalg.norm(target.pose.position - self.shoulder_position)
        if distance > self.reach_radius_m:
            position_error, orientation_error = residuals(self.fk(q_from), target)
            return ReachResult(False, q_from.copy(), OUT_OF_REACH, 0, 0, position_error,
                               float(np.rad2deg(orientation_error)))
        failures: list[tuple[int, IKAttempt]] = []
        iterations = 0
        seeds = [q_from, *self._aimed_seeds(target.pose.position)[:restarts]]
        rolled = 0
        while seeds:
            attempt = self.ik.solve(target, seeds.pop(0))
            iterations += attempt.iterations
            if not attempt.converged:
                failures.append((0 if not attempt.at_joint_limit else 1, attempt))
                continue
            if not self.joints.within_limits(attempt.q) or collisions.in_collision(attempt.q):
                failures.append((2, attempt))
            else:
                motion = move(q_from, attempt.q)
                if motion is not None:
                    return self._result(attempt, None, iterations, len(failures) + 1, motion)
                failures.append((3, attempt))
            if target.roll_free and rolled < MAX_ROLL_VARIANTS:
                # The same view with the sensor turned about its axis often clears the collision:
                # the roll joint turns the sensor about (nearly) its optical axis.
                rolled += 1
                roll = np.eye(self.joints.dof)[self.cell.roll_index]
                seeds.extend(attempt.q + roll * turn for turn in ROLL_TURNS)
        stage, attempt = max(failures, key=lambda item: item[0])
        return self._result(attempt, FAILURE_REASONS[stage], iterations, len(failures), None)

    @staticmethod
    def _result(attempt: IKAttempt, reason: FailureReason | None, iterations: int,
                attempts: int, motion: MotionPlan | None) -> ReachResult:
        return ReachResult(
            reachable=reason is None,
            q=attempt.q,
            reason=reason,
            iterations=iterations,
            attempts=attempts,
            position_error_m=attempt.position_error_m,
            orientation_error_deg=float(np.rad2deg(attempt.orientation_error_rad)),
            motion=motion,
        )

    def move_time(self, waypoints: np.ndarray) -> float:
        """Duration of a move along `waypoints` (m, dof) under the robot's velocity,
        acceleration and jerk limits, stopping at each corner (`time_move`)."""
        return time_move(waypoints, self.limits).duration_s

    def travel(self, q_from: np.ndarray, q_to: np.ndarray, center: np.ndarray,
               motion: MotionPlan | None = None, acquires: bool = True,
               timed: TimedMove | None = None) -> TravelCost:
        """All travel costs of the joint-space move `q_from` -> `q_to`, measured along the
        executed path: `motion`'s corners and samples, or the straight line when omitted.

        The joint costs add up over the straight segments between the corners (the robot stops
        at each corner); `paper` depends on the ends only; `cycle_time` is the move's duration
        under the time law plus, when it `acquires`, the sensor's acquisition time.

        Args:
            q_from: Start configuration.
            q_to: End configuration.
            center: Object centre for the paper's spherical approximation.
            motion: The executed move from `q_from` to `q_to`, when it is not the straight line.
            acquires: Whether the move ends at a view, where the robot stands still while the
                sensor acquires.
            timed: The move already timed (`time_move` of its corners), so that it is not
                timed again; timed here when omitted.
        """
        if motion is None:
            corners, path = np.array([q_from, q_to], dtype=float), self.path(q_from, q_to)
        else:
            corners, path = motion.waypoints, motion.path
        segments = list(itertools.pairwise(corners))
        velocity = self.joints.velocity_limits
        positions = self.forward.sensor_positions(path)
        return TravelCost(
            joint_time=sum(joint_time(a, b, velocity) for a, b in segments),
            joint_path=sum(joint_path_length(a, b) for a, b in segments),
            cartesian=polyline_length(positions),
            paper=paper_travel(positions[0], positions[-1], np.asarray(center, dtype=float)),
            cycle_time=(timed.duration_s if timed is not None else self.move_time(corners))
            + (self.cell.config.sensor.acquisition_time_s if acquires else 0.0),
        )
