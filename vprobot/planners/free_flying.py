"""Free-flying episodes: the sensor is placed at every requested pose, as in the paper.

There is no robot: nothing limits where the sensor goes and nothing of the arm occludes (the
sensor casts against the object and the fixture only, like the ground truth). The records keep
the robot at its start configuration and mark every view `reachable=False` with the reason
`free_flying`: the robot did not reach it, the free sensor took it. Travel is the paper's
spherical approximation only (the joint-space costs do not exist without a robot).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from vprobot.coverage import CoverageTracker
from vprobot.episode import EpisodeRecord, ViewRecord
from vprobot.ground_truth import ENVIRONMENT_GROUP
from vprobot.inspection import MotorScene
from vprobot.kinematics import TravelCost
from vprobot.kinematics.travel import paper_travel
from vprobot.planners.base import Episode, ViewRequest
from vprobot.scene import GEOM_GROUP_OBJECT
from vprobot.sensor import DepthSensor

FREE_FLYING = "free_flying"
"""The `reason` of every view of a free-flying episode."""


class FreeFlyingEpisode(Episode):
    """An episode whose sensor flies freely to every requested pose.

    Args:
        scene: The motor scene (its cell supplies the object, the fixture and the sensor).
        rotation: The object's rotation for this episode.
    """

    uses_robot: ClassVar[bool] = False

    def __init__(self, scene: MotorScene, rotation: np.ndarray):
        self.scene = scene
        self._data = scene.cell.make_data()
        self.object_pose = scene.cell.place_object(self._data, rotation)
        self._sensor = DepthSensor(scene.cell, resolution=scene.sensor.resolution,
                                   groups=(ENVIRONMENT_GROUP, GEOM_GROUP_OBJECT))
        self.tracker = CoverageTracker.from_ground_truth(scene.ground_truth)
        self._start = scene.cell.joints.home.copy()
        self._views: list[ViewRecord] = []

    @property
    def q(self) -> np.ndarray:
        return self._start.copy()

    @property
    def covered(self) -> np.ndarray:
        return self.tracker.covered

    @property
    def views(self) -> list[ViewRecord]:
        return self._views

    def preview(self, view: ViewRequest) -> np.ndarray:
        return self.tracker.match(
            self._sensor.acquire_from_pose(self._data, view.target.pose).points_mesh)

    def execute(self, view: ViewRequest) -> ViewRecord:
        pose = view.target.pose
        acquisition = self._sensor.acquire_from_pose(self._data, pose)
        step = self.tracker.update(acquisition.points_mesh, pose)
        previous = self._views[-1].sensor_pose if self._views else None
        travel = TravelCost(paper=paper_travel(previous.position, pose.position, self.center)
                            if previous is not None else 0.0)
        record = ViewRecord(requested=pose, reachable=False, reason=FREE_FLYING,
                            joints=self._start.copy(), path=None, sensor_pose=pose,
                            points_world=acquisition.points_world, coverage=step.coverage,
                            travel=travel)
        self._views.append(record)
        return record

    def record(self) -> EpisodeRecord:
        return EpisodeRecord(
            object_pose=self.object_pose,
            start_joints=self._start.copy(),
            views=list(self._views),
            gt_points_world=self.scene.ground_truth.points @ self.object_pose.rotation.T
            + self.center,
            covered=self.tracker.covered,
            mesh_path=str(self.scene.mesh.path),
        )
