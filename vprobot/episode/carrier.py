"""Sensor carriers: what moves the sensor to a requested view, and what the move costs.

An episode executes every request through its carrier: `robot` (`RobotCarrier`: the arm must
reach the view, within its limits, without collisions, along a collision-free joint-space path)
or `free` (`FreeCarrier`: the paper's free-flying sensor, placed at every requested pose). The
carrier owns the state its checks need (the object placement for collisions, the sensor's cell
state), so that the episode only keeps where the sensor is.
"""

from __future__ import annotations

import abc
from typing import ClassVar, Literal

import numpy as np

from vprobot.cell.sensor import Acquisition
from vprobot.episode.part_scene import PartScene
from vprobot.episode.records import ViewRecord, ViewRequest
from vprobot.geometry.poses import Pose

CarrierName = Literal["robot", "free"]
CARRIERS: tuple[CarrierName, ...] = ("robot", "free")


class Carrier(abc.ABC):
    """Moves the sensor of one episode: one object pose in one part's scene.

    Attributes:
        name: `robot` or `free`.
        uses_robot: Whether views are reached by the robot.
        scene: The part's scene.
        object_pose: Pose of the object's mesh frame in the world.
    """

    name: ClassVar[CarrierName]
    uses_robot: ClassVar[bool]

    def __init__(self, scene: PartScene, object_rotation: np.ndarray):
        self.scene = scene
        self.object_pose = Pose(scene.cell.object_center.copy(),
                                np.asarray(object_rotation, dtype=float))

    @property
    def center(self) -> np.ndarray:
        return self.object_pose.position

    @abc.abstractmethod
    def move(self, request: ViewRequest, joints: np.ndarray,
             pose: Pose | None) -> ViewRecord:
        """Execute `request` from the current state: the record of the motion (the sensor pose
        to acquire from, None when the sensor stays), without the acquisition.

        Args:
            request: The requested view.
            joints: The robot's current configuration.
            pose: The sensor pose of the latest acquisition; None before the first.
        """

    @abc.abstractmethod
    def acquire(self, move: ViewRecord) -> Acquisition:
        """The sensor's frame at the end of a move that reached a sensor pose."""

    @abc.abstractmethod
    def preview(self, request: ViewRequest) -> Acquisition:
        """The frame the request would give, simulated without moving.

        Raises:
            ValueError: If the request cannot be simulated (with the robot: it needs joints).
        """
