"""Episodes with the robot in the loop."""

from __future__ import annotations

import zlib
from typing import ClassVar

import numpy as np

from vprobot.episode import EpisodeRecord, ViewRecord
from vprobot.inspection import Inspection, MotorScene
from vprobot.planners.base import Episode, ViewRequest


def episode_rng(seed: int, scene: MotorScene) -> np.random.Generator:
    """The random stream of one (motor, seed): the same pose for every planner and run."""
    return np.random.default_rng([seed, zlib.crc32(scene.mesh.mesh_hash.encode())])


class RobotEpisode(Episode):
    """An episode in which the robot must reach every view (an `Inspection`).

    Args:
        scene: The motor scene.
        rotation: The object's rotation for this episode.
    """

    uses_robot: ClassVar[bool] = True

    def __init__(self, scene: MotorScene, rotation: np.ndarray):
        self.scene = scene
        self.inspection = Inspection(scene, rotation)
        self.object_pose = self.inspection.object_pose

    @property
    def q(self) -> np.ndarray:
        return self.inspection.q.copy()

    @property
    def covered(self) -> np.ndarray:
        return self.inspection.tracker.covered

    @property
    def views(self) -> list[ViewRecord]:
        return self.inspection.views

    def preview(self, view: ViewRequest) -> np.ndarray:
        """Acquire from the view's configuration (the arm occluding as it would) and match."""
        if view.joints is None:
            raise ValueError("a robot view can only be previewed from its joints")
        forward = self.scene.arm.forward
        forward.set_configuration(view.joints)
        return self.inspection.tracker.match(self.scene.sensor.acquire(forward.data).points_mesh)

    def execute(self, view: ViewRequest) -> ViewRecord:
        """Drive to the view's known configuration, or let the IK reach it from here.

        An unreachable request leaves the robot where it is and acquires nothing.
        """
        if view.joints is not None:
            try:
                return self.inspection.replay(view.joints, requested=view.target.pose).view
            except ValueError:
                # The straight joint-space path from here collides; the IK may find another
                # configuration (its restarts) with a free path.
                pass
        return self.inspection.request(view.target, unreachable="skip").view

    def record(self) -> EpisodeRecord:
        return self.inspection.record()
