"""What a planner asks for and what happened: a view request, a view record, an episode record.

The environment, the planners and a loaded plan JSON all produce an `EpisodeRecord`, so that one
renderer and one exporter serve them all.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from vprobot.geometry.poses import Pose
from vprobot.kinematics import SensorTarget, TravelCost
from vprobot.kinematics.trajectory import CycleTime, TimedMove, TimedPlan


@dataclasses.dataclass(frozen=True)
class ViewRequest:
    """A view a planner or agent asks for.

    Attributes:
        target: The requested sensor pose in the world.
        joints: A robot configuration known to reach the target (a screened candidate); the
            robot drives there directly when the joint-space path is free, else the IK is asked.
    """

    target: SensorTarget
    joints: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class ViewRecord:
    """One view request and its outcome.

    A carrier's move gives the record of the motion (the fields up to `sensor_pose`, and
    `travel`); the episode then adds what the sensor acquired there and the coverage.

    Attributes:
        requested: The requested sensor pose in the world.
        reachable: Whether the carrier took the view (a free-flying sensor takes every view).
        reason: Why not (`out_of_reach`, `did_not_converge`, `joint_limits`, `collision`,
            `path_not_found`).
        joints: Robot configuration after the step (unchanged when the robot stayed); None for
            a free-flying sensor.
        path: Joint-space path (n, dof) the robot moved along, sampled at the collision check's
            resolution; None when it stayed or without a robot.
        sensor_pose: Sensor pose the acquisition was made from; None when nothing was acquired.
        points_world: Acquired points in the world (0 rows when nothing was acquired, or not
            yet).
        pixels: The row-major pixel of the frame each acquired point was measured on.
        blocked_pixels: Pixels of the frame whose view of the object the robot or the cell
            blocked (`Acquisition.blocked_pixels`; empty when nothing was acquired).
        coverage: Cumulative coverage after this view (0 until the episode scored it).
        travel: Travel from the previous acquisition pose (zero when nothing moved), measured
            along `waypoints`. For the episode's first acquisition it is the approach from the
            start, not a step.
        waypoints: The corners of `path` (m, dof), m >= 2, from the previous configuration to
            `joints`; consecutive corners are joined by straight joint-space segments, each
            collision-free (two corners: the straight line was free). None when `path` is.
        timed: The move along `waypoints` timed under the robot's limits (`time_move`), once,
            when the carrier executed it; None when `waypoints` is.
    """

    requested: Pose
    reachable: bool
    reason: str | None
    joints: np.ndarray | None
    path: np.ndarray | None
    sensor_pose: Pose | None
    points_world: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 3)))
    coverage: float = 0.0
    travel: TravelCost = dataclasses.field(default_factory=TravelCost)
    pixels: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    blocked_pixels: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=np.int64))
    waypoints: np.ndarray | None = None
    timed: TimedMove | None = None

    @property
    def acquired(self) -> bool:
        return self.sensor_pose is not None


@dataclasses.dataclass(frozen=True)
class EpisodeRecord:
    """A whole episode in one cell.

    Attributes:
        carrier: `robot` (the robot reached every view) or `free` (free-flying sensor).
        object_pose: Pose of the object (its mesh frame) in the world during the episode.
        start_joints: Robot configuration before the first view.
        views: The views in order (the initial acquisition first, when there was one).
        gt_points_world: Ground-truth points in the world.
        first_covered_by: Per GT point, the index in `views` of the view that first covered it,
            -1 for a point never covered.
        epsilon_m: Coverage matching distance: a GT point is covered by an acquired point
            within it.
        mesh_path: The mesh file, when the object came from one.
        return_waypoints: The corners (m, dof) of the robot's collision-free move from its last
            configuration back to `start_joints`, the cycle's return; None without a robot,
            before the first acquisition, or when no path back was found.
        timed: The cycle (docs/motion.md#cycle-time): the approach, the moves between views and
            the return, each timed once as it was executed, on the cycle's clock
            (`timed_cycle`); None where `return_waypoints` is, or where a move is untimed.
    """

    carrier: str
    object_pose: Pose
    start_joints: np.ndarray
    views: list[ViewRecord]
    gt_points_world: np.ndarray
    first_covered_by: np.ndarray
    epsilon_m: float
    mesh_path: str | None = None
    return_waypoints: np.ndarray | None = None
    timed: TimedPlan | None = None

    @property
    def cycle(self) -> CycleTime | None:
        """The cycle time of the part and its parts (`timed`'s); None where `timed` is."""
        return None if self.timed is None else self.timed.cycle

    @property
    def covered(self) -> np.ndarray:
        """Which ground-truth points are covered at the end."""
        return self.first_covered_by >= 0

    @property
    def coverage(self) -> float:
        return self.views[-1].coverage if self.views else 0.0

    @property
    def approach(self) -> TravelCost:
        """The move from the start to the first acquisition: reported, but not a step."""
        return split_travel(self.views)[0]

    @property
    def travel_sum(self) -> TravelCost:
        """k_cum: the moves between the episode's acquisitions (the approach excluded)."""
        return split_travel(self.views)[1]


def split_travel(views: Sequence[ViewRecord]) -> tuple[TravelCost, TravelCost]:
    """The approach (the move to the first acquisition) and k_cum (all later moves).

    docs/states-actions-rewards.md#travel-costs: k_cum sums the moves between the acquisitions of
    an episode; the approach from the start configuration to the first view is reported
    separately.
    """
    approach, total = TravelCost(), TravelCost()
    acquired = False
    for view in views:
        if acquired:
            total = total + view.travel
        elif view.acquired:
            approach, acquired = view.travel, True
    return approach, total
