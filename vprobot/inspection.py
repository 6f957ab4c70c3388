"""An inspection in progress: request a view, let the robot reach it, acquire, update coverage.

`MotorScene` bundles what one motor mesh needs (cell, robot arm, sensor, ground truth) and is
built once per mesh; `Inspection` is one episode in it. The gymnasium environment, the planners
and the renderer all go through these two, so that a view is executed the same way everywhere.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Literal

import numpy as np

from vprobot.config import Config, EnvConfig
from vprobot.coverage import CoverageStep, CoverageTracker
from vprobot.episode import EpisodeRecord, ViewRecord
from vprobot.geometry import (
    Pose,
    rotation_about_x,
    rotation_about_y,
    rotation_about_z,
    spherical_position,
)
from vprobot.ground_truth import GroundTruth, ground_truth
from vprobot.kinematics import ReachResult, RobotArm, SensorTarget, TravelCost
from vprobot.kinematics.path import first_collision
from vprobot.mesh_loading import LoadedMesh, load_mesh
from vprobot.scene import Cell
from vprobot.sensor import DepthSensor

UnreachablePolicy = Literal["skip", "nearest"]


def random_object_rotation(env: EnvConfig, rng: np.random.Generator) -> np.ndarray:
    """An episode's object rotation (SPEC section 3): about the vertical by U[-yaw, yaw], then
    tilted by U[-tilt, tilt] about the world x or y axis (equally likely), drawn in that order."""
    yaw = np.deg2rad(rng.uniform(-env.object_yaw_range_deg, env.object_yaw_range_deg))
    tilt = np.deg2rad(rng.uniform(-env.object_tilt_range_deg, env.object_tilt_range_deg))
    tilt_about = rotation_about_x if rng.integers(2) == 0 else rotation_about_y
    return tilt_about(tilt) @ rotation_about_z(yaw)


def initial_view_target(config: Config, center: np.ndarray) -> SensorTarget:
    """The fixed initial view (paper: phi 1.42, theta 0.71 rad at the working distance)."""
    offset = spherical_position(config.env.initial_phi_rad, config.env.initial_theta_rad,
                                config.sensor.working_distance_m)
    return SensorTarget.look_at(center + offset, center)


@dataclasses.dataclass
class MotorScene:
    """Everything that depends on one motor mesh: built once, reused across episodes.

    Attributes:
        mesh: The loaded mesh (centred; `mesh.offset` and `mesh.scale` place the file).
        cell: The compiled cell holding it.
        arm: Robot kinematics in that cell (its MjData is where acquisitions happen).
        sensor: The depth sensor at the chosen resolution.
        ground_truth: P_GT of the mesh (mesh frame).
    """

    mesh: LoadedMesh
    cell: Cell
    arm: RobotArm
    sensor: DepthSensor
    ground_truth: GroundTruth

    @classmethod
    def load(cls, config: Config, mesh_path: str | Path, scale: float = 1.0,
             resolution: tuple[int, int] | None = None) -> MotorScene:
        """Load a mesh file and build its cell, arm, sensor and ground truth.

        Raises:
            FileNotFoundError, ValueError: For a missing, unreadable, empty or mis-scaled mesh.
        """
        mesh = load_mesh(mesh_path, scale)
        cell = Cell(config, mesh.mesh)
        return cls(
            mesh=mesh,
            cell=cell,
            arm=RobotArm(cell),
            sensor=DepthSensor(cell, resolution=resolution),
            ground_truth=ground_truth(mesh.mesh, config),
        )

    def object_block(self, object_pose: Pose) -> dict[str, object]:
        """How to place the mesh file, as stored on disk, into the world (plan JSON).

        The loader scaled the file's vertices by `scale` and subtracted `offset`; a file vertex
        v therefore lands at position + R (scale * v - offset) = position' + R scale v.
        """
        position = object_pose.position - object_pose.rotation @ self.mesh.offset
        return {
            "mesh": str(self.mesh.path),
            "position": [float(x) for x in position],
            "quaternion": [float(x) for x in object_pose.quaternion],
            "scale": float(self.mesh.scale),
        }


@dataclasses.dataclass(frozen=True)
class StepOutcome:
    """What one requested view did.

    Attributes:
        view: The record of the view (for rendering and export).
        reach: The robot's verdict on the request.
        coverage: The coverage update, when something was acquired.
    """

    view: ViewRecord
    reach: ReachResult
    coverage: CoverageStep | None


class Inspection:
    """One inspection episode of a motor scene.

    Args:
        scene: The motor scene.
        object_rotation: Rotation of the object about its centre (3x3) for this episode.
        start_joints: Initial robot configuration; `home` when omitted.
    """

    def __init__(self, scene: MotorScene, object_rotation: np.ndarray,
                 start_joints: np.ndarray | None = None):
        self.scene = scene
        self.object_pose = scene.arm.place_object(object_rotation)
        self.tracker = CoverageTracker.from_ground_truth(scene.ground_truth)
        joints = scene.cell.joints
        self.start_joints = joints.home.copy() if start_joints is None else joints.check(
            start_joints, "start_joints")
        self.q = self.start_joints.copy()
        self.views: list[ViewRecord] = []
        self.travel_sum = TravelCost()

    @property
    def coverage(self) -> float:
        return self.tracker.coverage

    @property
    def center(self) -> np.ndarray:
        return self.object_pose.position

    def sensor_pose(self) -> Pose:
        """Current sensor pose in the world."""
        return self.scene.arm.fk(self.q)

    def _feasible_nearest(self, result: ReachResult) -> bool:
        """Whether the configuration a failed IK ended in can be driven to and used."""
        arm = self.scene.arm
        return (result.reason in ("did_not_converge", "joint_limits")
                and not arm.in_collision(result.q)
                and first_collision(arm.collisions, arm.path(self.q, result.q)) is None)

    def request(self, target: SensorTarget,
                unreachable: UnreachablePolicy = "skip") -> StepOutcome:
        """Reach for `target` from the current configuration and acquire there.

        Args:
            target: The requested sensor pose (world).
            unreachable: `skip`: an unreachable request leaves the robot where it is and
                acquires nothing; `nearest`: if the IK's closest configuration is collision-free
                and connected by a free path, move there and acquire.
        """
        arm = self.scene.arm
        result = arm.reach(target, self.q)
        moved = result.reachable or (unreachable == "nearest" and self._feasible_nearest(result))
        if not moved:
            view = ViewRecord(requested=target.pose, reachable=False, reason=result.reason,
                              joints=self.q.copy(), path=None, sensor_pose=None,
                              points_world=np.zeros((0, 3)), coverage=self.coverage)
            self.views.append(view)
            return StepOutcome(view, result, None)
        path = result.path if result.path is not None else arm.path(self.q, result.q)
        return self._move_and_acquire(target.pose, result, path)

    def replay(self, joints: np.ndarray, requested: Pose | None = None) -> StepOutcome:
        """Drive to a given configuration (e.g. from an exported plan) and acquire there.

        Raises:
            ValueError: If the configuration or the straight path to it is in collision, or
                outside the joint limits.
        """
        arm = self.scene.arm
        joints = arm.joints.check(joints, "joints")
        if not arm.joints.within_limits(joints):
            raise ValueError(f"joints {np.round(joints, 4).tolist()} are outside the limits")
        path = arm.path(self.q, joints)
        if first_collision(arm.collisions, path) is not None:
            raise ValueError(f"the path to joints {np.round(joints, 4).tolist()} collides")
        pose = arm.fk(joints)
        result = ReachResult(True, joints, None, 0, 0, 0.0, 0.0, path)
        return self._move_and_acquire(requested if requested is not None else pose, result, path)

    def _move_and_acquire(self, requested: Pose, result: ReachResult,
                          path: np.ndarray) -> StepOutcome:
        arm = self.scene.arm
        travel = arm.travel(self.q, result.q, self.center)
        self.q = result.q.copy()
        arm.forward.set_configuration(self.q)
        acquisition = self.scene.sensor.acquire(arm.forward.data)
        step = self.tracker.update(acquisition.points_mesh, acquisition.sensor_pose)
        self.travel_sum = self.travel_sum + travel
        view = ViewRecord(requested=requested, reachable=result.reachable, reason=result.reason,
                          joints=self.q.copy(), path=path, sensor_pose=acquisition.sensor_pose,
                          points_world=acquisition.points_world, coverage=step.coverage,
                          travel=travel)
        self.views.append(view)
        return StepOutcome(view, result, step)

    def gt_points_world(self) -> np.ndarray:
        return self.scene.ground_truth.points @ self.object_pose.rotation.T + self.center

    def record(self) -> EpisodeRecord:
        """The episode so far, for rendering and export."""
        return EpisodeRecord(
            object_pose=self.object_pose,
            start_joints=self.start_joints.copy(),
            views=list(self.views),
            gt_points_world=self.gt_points_world(),
            covered=self.tracker.covered.copy(),
            mesh_path=str(self.scene.mesh.path),
        )
