"""What happened in an inspection episode: one record per view, as the renderer and exports need.

The environment, the planners and a loaded plan JSON all produce an `EpisodeRecord`, so that one
renderer and one exporter serve them all.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vprobot.geometry import Pose
from vprobot.kinematics import TravelCost


@dataclasses.dataclass(frozen=True)
class ViewRecord:
    """One acquisition request and its outcome.

    Attributes:
        requested: The requested sensor pose in the world.
        reachable: Whether the robot reached it.
        reason: Why not (`did_not_converge`, `joint_limits`, `collision`, `path_collision`).
        joints: Robot configuration after the step (unchanged when the robot stayed).
        path: Joint-space path (n, dof) the robot moved along; None when it stayed.
        sensor_pose: Sensor pose the acquisition was made from; None when nothing was acquired.
        points_world: Acquired points in the world (0 rows when nothing was acquired).
        coverage: Cumulative coverage after this view.
        travel: Travel from the previous configuration (zero when the robot stayed).
    """

    requested: Pose
    reachable: bool
    reason: str | None
    joints: np.ndarray
    path: np.ndarray | None
    sensor_pose: Pose | None
    points_world: np.ndarray
    coverage: float
    travel: TravelCost = dataclasses.field(default_factory=TravelCost)


@dataclasses.dataclass(frozen=True)
class EpisodeRecord:
    """A whole episode in one cell.

    Attributes:
        object_pose: Pose of the object (its mesh frame) in the world during the episode.
        start_joints: Robot configuration before the first view.
        views: The views in order (the initial acquisition first, when there was one).
        gt_points_world: Ground-truth points in the world.
        covered: Which ground-truth points are covered at the end.
        mesh_path: The mesh file, when the object came from one.
    """

    object_pose: Pose
    start_joints: np.ndarray
    views: list[ViewRecord]
    gt_points_world: np.ndarray
    covered: np.ndarray
    mesh_path: str | None = None

    @property
    def coverage(self) -> float:
        return self.views[-1].coverage if self.views else 0.0

    @property
    def travel(self) -> TravelCost:
        total = TravelCost()
        for view in self.views:
            total = total + view.travel
        return total
