"""The paper's free-flying sensor: placed at every requested pose, nothing of a robot in the way."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from vprobot.cell.sensor import Acquisition
from vprobot.episode.carrier import Carrier, CarrierName
from vprobot.episode.records import ViewRecord, ViewRequest
from vprobot.geometry.poses import Pose
from vprobot.kinematics import TravelCost
from vprobot.kinematics.travel import paper_travel


class FreeCarrier(Carrier):
    """Every request is executed exactly at its pose; the sensor sees the object and the fixture
    only (like the ground truth). Travel is the straight sensor path (`cartesian`) and the
    paper's approximation (`paper`); the joint-space costs do not exist without a robot."""

    name: ClassVar[CarrierName] = "free"
    uses_robot: ClassVar[bool] = False

    def move(self, request: ViewRequest, joints: np.ndarray, pose: Pose | None) -> ViewRecord:
        target = request.target.pose
        travel = TravelCost() if pose is None else TravelCost(
            cartesian=float(np.linalg.norm(target.position - pose.position)),
            paper=paper_travel(pose.position, target.position, self.center))
        return ViewRecord(requested=target, reachable=True, reason=None, joints=None, path=None,
                          sensor_pose=target, travel=travel)

    def acquire(self, move: ViewRecord) -> Acquisition:
        if move.sensor_pose is None:
            raise ValueError("an unreached view has no frame to acquire")
        return self.scene.free_sensor.acquire_at(move.sensor_pose, self.object_pose.rotation)

    def preview(self, request: ViewRequest) -> Acquisition:
        return self.scene.free_sensor.acquire_at(request.target.pose, self.object_pose.rotation)
