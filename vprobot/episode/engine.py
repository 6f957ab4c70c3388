"""The inspection engine: one episode, executed view by view through its sensor carrier.

The gymnasium env, the planners, the evaluation, plan replay and the renderer all run episodes
through `Episode`, so that a view is executed, acquired, scored and recorded the same way
everywhere, with the robot in the loop (`carrier="robot"`) or a free-flying sensor (`"free"`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

import numpy as np

from vprobot.coverage.occupancy import EpisodeGrid, GridSettings
from vprobot.coverage.tracker import CoverageTracker
from vprobot.episode.carrier import CARRIERS, Carrier, CarrierName
from vprobot.episode.cycle import timed_cycle
from vprobot.episode.free_carrier import FreeCarrier
from vprobot.episode.part_scene import PartScene
from vprobot.episode.records import EpisodeRecord, ViewRecord, ViewRequest
from vprobot.episode.robot_carrier import RobotCarrier
from vprobot.episode.shared import SharedWork
from vprobot.episode.specs import EpisodeSpec
from vprobot.geometry.poses import Pose
from vprobot.kinematics import TravelCost
from vprobot.kinematics.trajectory import TimedMove, time_move


def make_carrier(name: CarrierName, scene: PartScene, object_rotation: np.ndarray,
                 unreachable: str = "skip", shared: SharedWork | None = None) -> Carrier:
    """The carrier by name; the robot keeps its planned moves in `shared` (`RobotCarrier`).

    Raises:
        ValueError: For an unknown name.
    """
    if name == "robot":
        return RobotCarrier(scene, object_rotation, unreachable, shared)
    if name == "free":
        return FreeCarrier(scene, object_rotation)
    raise ValueError(f"unknown carrier {name!r}; allowed: {', '.join(CARRIERS)}")


class Episode:
    """One inspection of a part's scene in one object pose.

    Args:
        scene: The part's scene.
        object_rotation: Rotation of the object about its centre (3x3) for this episode.
        carrier: `robot` (IK, limits, collisions, joint-space paths) or `free` (free-flying
            sensor, every request executed).
        unreachable: With the robot, `skip` or `nearest` (see `RobotCarrier`).
        start_joints: Initial robot configuration; `home` when omitted.
        shared: The work shared with the other episodes that start alike (`SharedWork`: the
            planners of one spec and carrier in `evaluate`); its own when omitted.

    Attributes:
        shared: Results computed from the episode's start, for every planner that asks.
        approach: The move from the start to the first acquisition (`split_travel`'s).
        travel_sum: k_cum so far: the moves between acquisitions, the approach excluded
            (`split_travel`'s, summed view by view as they come).

    Raises:
        ValueError: For an unknown carrier or policy, bad start joints, or `shared` serving
            an episode that starts otherwise.
    """

    def __init__(self, scene: PartScene, object_rotation: np.ndarray,
                 carrier: CarrierName = "robot", unreachable: str = "skip",
                 start_joints: np.ndarray | None = None, shared: SharedWork | None = None):
        self.scene = scene
        self.shared = shared if shared is not None else SharedWork()
        self.carrier: Carrier = make_carrier(carrier, scene, object_rotation, unreachable,
                                             self.shared)
        self.object_pose = self.carrier.object_pose
        self.tracker = CoverageTracker.from_ground_truth(scene.ground_truth)
        joints = scene.cell.joints
        self.start_joints = joints.start.copy() if start_joints is None else joints.check(
            start_joints, "start_joints")
        self.q = self.start_joints.copy()
        self.shared.bind(scene, self.object_pose.rotation, carrier, self.start_joints)
        self.pose: Pose | None = None
        self.views: list[ViewRecord] = []
        self.approach = TravelCost()
        self.travel_sum = TravelCost()
        self._first_covered_by = np.full(len(scene.ground_truth.points), -1)
        self._grids: dict[GridSettings, EpisodeGrid] = {}
        # The way back to the start, planned and timed once per configuration it leaves from.
        self._return: tuple[np.ndarray, TimedMove | None] | None = None

    @classmethod
    def from_spec(cls, scene: PartScene, spec: EpisodeSpec, carrier: CarrierName = "robot",
                  unreachable: str = "skip", shared: SharedWork | None = None) -> Episode:
        """The episode of a spec (its initial view is not taken yet: see `begin`); `shared` as
        in `Episode`."""
        return cls(scene, spec.rotation, carrier, unreachable, shared=shared)

    @property
    def uses_robot(self) -> bool:
        return self.carrier.uses_robot

    @property
    def robot(self) -> RobotCarrier:
        """The carrier of an episode that `uses_robot`, as the robot's (collisions, paths).

        Raises:
            RuntimeError: If the episode's views are not reached by the robot.
        """
        if not isinstance(self.carrier, RobotCarrier):
            raise RuntimeError(f"the {self.carrier.name} carrier has no robot")
        return self.carrier

    @property
    def center(self) -> np.ndarray:
        """The object's centre in the world."""
        return self.object_pose.position

    @property
    def coverage(self) -> float:
        return self.tracker.coverage

    @property
    def covered(self) -> np.ndarray:
        """Which ground-truth points are covered so far (a copy)."""
        return self.tracker.covered

    def sensor_pose(self) -> Pose:
        """Where the sensor is: the robot's FK, or the free sensor's latest pose.

        Raises:
            RuntimeError: For a free sensor that has not acquired yet.
        """
        if self.uses_robot:
            return self.scene.arm.fk(self.q)
        if self.pose is None:
            raise RuntimeError("the free sensor has no pose before its first view")
        return self.pose

    def begin(self, requests: Iterable[ViewRequest]) -> ViewRecord:
        """Take the initial view: the first of `requests` the carrier reaches.

        Requests it does not reach leave no trace in the episode.

        Raises:
            ValueError: If none is reached (the object or the cell placement leaves the robot
                no initial view).
        """
        reasons = []
        for request in requests:
            move = self.carrier.move(request, self.q, self.pose)
            if move.reachable and move.acquired:
                return self._execute(move)
            reasons.append(move.reason)
        why = ", ".join(sorted(set(map(str, reasons))))
        raise ValueError(f"none of the {len(reasons)} initial views is reachable ({why}); check "
                         f"the object and the cell placement")

    def request(self, request: ViewRequest) -> ViewRecord:
        """Move to the view if the carrier can and acquire there; never acquires from an
        unreached pose (unless the robot's `nearest` policy moved it elsewhere)."""
        return self._execute(self.carrier.move(request, self.q, self.pose))

    def replay(self, joints: np.ndarray, requested: Pose | None = None,
               waypoints: np.ndarray | None = None) -> ViewRecord:
        """Drive the robot to a given configuration (e.g. from a plan) and acquire there, along
        the given corners of the move when there are (a plan's), else on a planned move.

        Raises:
            ValueError: Without a robot, or if the configuration or the move to it is in
                collision or outside the joint limits (`RobotCarrier.drive`).
        """
        if not isinstance(self.carrier, RobotCarrier):
            raise ValueError("joints can be replayed only with the robot carrier")
        return self._execute(self.carrier.drive(self.q, joints, requested, waypoints))

    def skip(self, requested: Pose, reason: str) -> ViewRecord:
        """Record a request that was not executed (e.g. a plan's unreachable view)."""
        return self._execute(ViewRecord(requested=requested, reachable=False, reason=reason,
                                        joints=self._joints(), path=None, sensor_pose=None))

    def preview(self, request: ViewRequest) -> np.ndarray:
        """Which GT points the view alone would cover, simulated without executing it.

        Raises:
            ValueError: If the view cannot be simulated (with the robot: it needs joints).
        """
        return self.tracker.match(self.carrier.preview(request).points_mesh)

    def _joints(self) -> np.ndarray | None:
        return self.q.copy() if self.uses_robot else None

    def _execute(self, move: ViewRecord) -> ViewRecord:
        """Acquire at the end of a carrier's move, score and record the view."""
        acquired_before = self.pose is not None  # the first acquisition sets it
        points_world = np.zeros((0, 3))
        pixels = blocked = np.zeros(0, dtype=np.int64)
        if move.acquired:
            acquisition = self.carrier.acquire(move)
            before = self.tracker.covered
            self.tracker.update(acquisition.points_mesh, move.sensor_pose)
            self._first_covered_by[self.tracker.covered & ~before] = len(self.views)
            points_world, pixels = acquisition.points_world, acquisition.pixels
            blocked = acquisition.blocked_pixels
            if move.joints is not None:
                self.q = move.joints.copy()
            self.pose = move.sensor_pose
        view = dataclasses.replace(move, joints=self._joints(), points_world=points_world,
                                   coverage=self.coverage, pixels=pixels, blocked_pixels=blocked)
        if acquired_before:
            self.travel_sum = self.travel_sum + view.travel
        elif view.acquired:
            self.approach = view.travel
        self.views.append(view)
        return view

    def occupancy(self, settings: GridSettings) -> EpisodeGrid:
        """The episode's occupancy grid of these settings, with every frame acquired so far
        integrated: made on first need, each frame integrated once however many readers share
        it (the agent's state, the planners, the stop rules, the coverage estimate)."""
        grid = self._grids.get(settings)
        if grid is None:
            grid = self._grids[settings] = EpisodeGrid(settings)
        grid.update(self.views)
        return grid

    def record(self) -> EpisodeRecord:
        """The episode so far, for rendering and export, with its cycle timed (`timed_cycle`)."""
        gt = self.scene.ground_truth.points
        back = self._return_move()
        return EpisodeRecord(
            carrier=self.carrier.name,
            object_pose=self.object_pose,
            start_joints=self.start_joints.copy(),
            views=list(self.views),
            gt_points_world=gt @ self.object_pose.rotation.T + self.center,
            first_covered_by=self._first_covered_by.copy(),
            epsilon_m=self.tracker.epsilon,
            mesh_path=str(self.scene.mesh.path),
            return_waypoints=None if back is None else back.waypoints,
            timed=timed_cycle(self.views, back, self.scene.cell),
        )

    def _return_move(self) -> TimedMove | None:
        """The robot's move back to its start, timed (`EpisodeRecord.return_waypoints`)."""
        if not isinstance(self.carrier, RobotCarrier) or not any(v.acquired for v in self.views):
            return None
        if self._return is None or not np.array_equal(self._return[0], self.q):
            motion = self.carrier.plan(self.q, self.start_joints)
            self._return = (self.q.copy(), None if motion is None
                            else time_move(motion.waypoints, self.scene.arm.limits))
        return self._return[1]
