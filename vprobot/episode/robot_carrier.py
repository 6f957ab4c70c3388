"""The robot in the loop: IK, joint limits, collisions, collision-free moves, all travel costs."""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from vprobot.cell.sensor import Acquisition
from vprobot.episode.carrier import Carrier, CarrierName
from vprobot.episode.part_scene import PartScene
from vprobot.episode.records import ViewRecord, ViewRequest
from vprobot.episode.shared import SharedWork
from vprobot.geometry.poses import Pose
from vprobot.kinematics import UNSOLVED, ReachResult, SensorTarget
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.motion_planner import MotionPlan
from vprobot.kinematics.trajectory import JOIN_TOLERANCE_RAD, time_move

UnreachablePolicy = Literal["skip", "nearest"]
UNREACHABLE_POLICIES: tuple[UnreachablePolicy, ...] = ("skip", "nearest")


class RobotCarrier(Carrier):
    """The scene's arm carries the sensor; the arm occludes what it stands in front of.

    Args:
        scene: The part's scene.
        object_rotation: The object's rotation for this episode.
        unreachable: `skip`: an unreachable request leaves the robot where it is and acquires
            nothing; `nearest`: if the IK's closest configuration is collision-free and a
            collision-free move joins it, move there and acquire.
        shared: Where the planned moves, the reached targets and the frames taken are kept, by
            their ends, by the target and start configuration, and by the sensor pose and
            configuration: an episode's `SharedWork`, so that the planners of one spec and
            carrier plan each move, reach each target and take each frame once (each depends
            on those arguments only); the carrier's own when omitted.

    Raises:
        ValueError: For an unknown unreachable policy.
    """

    name: ClassVar[CarrierName] = "robot"
    uses_robot: ClassVar[bool] = True

    def __init__(self, scene: PartScene, object_rotation: np.ndarray,
                 unreachable: str = "skip", shared: SharedWork | None = None):
        if unreachable not in UNREACHABLE_POLICIES:
            raise ValueError(f"unreachable must be one of {list(UNREACHABLE_POLICIES)}, got "
                             f"{unreachable!r}")
        super().__init__(scene, object_rotation)
        self.arm = scene.arm
        self.collisions = CollisionChecker(scene.cell, object_rotation)
        self.unreachable = unreachable
        self.shared = shared if shared is not None else SharedWork()

    def plan(self, q_from: np.ndarray, q_to: np.ndarray) -> MotionPlan | None:
        """The collision-free move between two configurations in this episode's cell (the
        straight line when free, else planned per `kinematics.path_planner`), or None; each
        move is planned once (`shared`)."""
        q_from, q_to = (np.asarray(q, dtype=float) for q in (q_from, q_to))
        return self.shared.get(("move", q_from.tobytes(), q_to.tobytes()),
                               lambda: self.arm.plan(q_from, q_to, self.collisions))

    def reach(self, target: SensorTarget, q_from: np.ndarray) -> ReachResult:
        """The IK of `target` from `q_from` in this episode's cell and the move to its solution
        (`RobotArm.reach`, the move planned by `plan`, so that executing the view drives it
        unplanned); each target is reached once per start configuration (`shared`: `nbv` and
        `nbv@grid` try the same targets from the same configurations). The result's `q` is
        read-only."""
        q_from = np.asarray(q_from, dtype=float)

        def solve() -> ReachResult:
            result = self.arm.reach(target, q_from, self.collisions, plan=self.plan)
            result.q.flags.writeable = False
            return result

        look_at = target.look_at_point
        return self.shared.get(("reach", target.pose.position.tobytes(),
                                target.pose.rotation.tobytes(), target.roll_free,
                                None if look_at is None else look_at.tobytes(),
                                q_from.tobytes()), solve)

    def path_is_free(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        """Whether a collision-free move joins two configurations (`plan` finds one)."""
        return self.plan(q_from, q_to) is not None

    def drive(self, q_from: np.ndarray, joints: np.ndarray, requested: Pose | None = None,
              waypoints: np.ndarray | None = None) -> ViewRecord:
        """Drive to a given configuration (e.g. a screened candidate or a stored plan);
        `requested` is the pose asked for (by default the one the configuration reaches).

        Args:
            q_from: The current configuration.
            joints: The configuration to drive to.
            requested: The pose asked for.
            waypoints: The corners of the move to take (a stored plan's), from `q_from` to
                `joints`; planned here when omitted.

        Raises:
            ValueError: If the configuration is outside the limits, no collision-free move to
                it was found, or the given corners do not join `q_from` to `joints` or collide.
        """
        arm = self.arm
        joints = arm.joints.check(joints, "joints")
        if not arm.joints.within_limits(joints):
            raise ValueError(f"joints {np.round(joints, 4).tolist()} are outside the limits")
        if waypoints is None:
            motion = self.plan(q_from, joints)
        else:
            corners = np.asarray(waypoints, dtype=float)
            if (corners.ndim != 2 or len(corners) < 2
                    or not np.allclose(corners[0], q_from, atol=JOIN_TOLERANCE_RAD)
                    or not np.allclose(corners[-1], joints, atol=JOIN_TOLERANCE_RAD)):
                raise ValueError("the waypoints must run from the current configuration to "
                                 f"joints {np.round(joints, 4).tolist()}")
            motion = arm.follow(corners, self.collisions)
            if motion is None:
                raise ValueError(f"the path along the waypoints to joints "
                                 f"{np.round(joints, 4).tolist()} collides or leaves the limits")
        if motion is None:
            raise ValueError(f"no collision-free path to joints {np.round(joints, 4).tolist()} "
                             "was found")
        return self._executed(requested, q_from, joints, motion, reachable=True, reason=None)

    def _executed(self, requested: Pose | None, q_from: np.ndarray, joints: np.ndarray,
                  motion: MotionPlan, reachable: bool, reason: str | None) -> ViewRecord:
        pose = self.arm.fk(joints)
        # Timed here, once: its travel's cycle time and the episode's cycle read this timing.
        timed = time_move(motion.waypoints, self.arm.limits)
        return ViewRecord(requested=pose if requested is None else requested,
                          reachable=reachable, reason=reason, joints=joints.copy(),
                          path=motion.path, waypoints=motion.waypoints, sensor_pose=pose,
                          travel=self.arm.travel(q_from, joints, self.center, motion,
                                                 timed=timed),
                          timed=timed)

    def _feasible_nearest(self, result: ReachResult, q_from: np.ndarray) -> MotionPlan | None:
        """The move to the configuration a failed IK ended in, when it can be driven to and
        used; else None."""
        if (result.reason in UNSOLVED and self.arm.joints.within_limits(result.q)
                and not self.collisions.in_collision(result.q)):
            return self.plan(q_from, result.q)
        return None

    def move(self, request: ViewRequest, joints: np.ndarray,
             pose: Pose | None = None) -> ViewRecord:
        """Drive to the request's known configuration, or let the IK reach it from here."""
        requested = request.target.pose
        if request.joints is not None:
            try:
                return self.drive(joints, request.joints, requested)
            except ValueError:
                # No collision-free move from here was found; the IK may find another
                # configuration (its restarts) that one joins.
                pass
        result = self.reach(request.target, joints)
        if result.motion is not None:
            return self._executed(requested, joints, result.q, result.motion, True, None)
        nearest = self._feasible_nearest(result, joints) if self.unreachable == "nearest" else None
        if nearest is not None:
            return self._executed(requested, joints, result.q, nearest, False, result.reason)
        return ViewRecord(requested=requested, reachable=False, reason=result.reason,
                          joints=joints.copy(), path=None, sensor_pose=None)

    def acquire(self, move: ViewRecord) -> Acquisition:
        if move.sensor_pose is None or move.joints is None:
            raise ValueError("an unreached view has no frame to acquire")
        return self._frame(move.sensor_pose, move.joints)

    def preview(self, request: ViewRequest) -> Acquisition:
        """Acquire from the request's configuration (the arm occluding as it would)."""
        if request.joints is None:
            raise ValueError("a robot view can only be previewed from its joints")
        return self._frame(self.arm.fk(request.joints), request.joints)

    def _frame(self, pose: Pose, joints: np.ndarray) -> Acquisition:
        """The frame from `pose` with the arm at `joints`, taken once (`shared`): a preview and
        the view executed there, by any planner of the episode, measure the same (the sensing
        model's draws are seeded by the poses). Its arrays are read-only."""
        joints = np.asarray(joints, dtype=float)

        def take() -> Acquisition:
            frame = self.scene.sensor.acquire_at(pose, self.object_pose.rotation, joints)
            for array in (frame.points_world, frame.points_object, frame.pixels,
                          frame.blocked_pixels):
                array.flags.writeable = False
            return frame

        return self.shared.get(("frame", pose.position.tobytes(), pose.rotation.tobytes(),
                                joints.tobytes()), take)
