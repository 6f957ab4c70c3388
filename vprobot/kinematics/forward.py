"""Forward kinematics: joint configuration -> sensor (and flange) pose in the world."""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.geometry.poses import Pose


class ForwardKinematics:
    """Evaluates frame poses of the cell's robot on its own MjData (robot frames only).

    Args:
        cell: The compiled cell.
    """

    def __init__(self, cell: Cell):
        self.cell = cell
        self.data = cell.make_data()

    def _set_configuration(self, q: np.ndarray) -> None:
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.cell.model, self.data)

    def sensor_pose(self, q: np.ndarray) -> Pose:
        """Pose of the sensor frame (+z viewing direction) in the world at `q`."""
        self._set_configuration(self.cell.joints.check(q))
        site = self.cell.sensor_site_id
        return Pose(
            self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy()
        )

    def flange_pose(self, q: np.ndarray) -> Pose:
        """Pose of the flange frame (the description's `flange`) in the world at `q`."""
        self._set_configuration(self.cell.joints.check(q))
        body = self.cell.flange_body_id
        return Pose(
            self.data.xpos[body].copy(), self.data.xmat[body].reshape(3, 3).copy()
        )

    def body_position(self, body: int, q: np.ndarray) -> np.ndarray:
        """Position of a robot body's frame (by body id) in the world at `q`."""
        self._set_configuration(self.cell.joints.check(q))
        return self.data.xpos[body].copy()

    def sensor_positions(self, configurations: np.ndarray) -> np.ndarray:
        """Sensor positions (n, 3) along a sequence of configurations (n, dof)."""
        positions = np.empty((len(configurations), 3))
        for index, q in enumerate(configurations):
            self._set_configuration(q)
            positions[index] = self.data.site_xpos[self.cell.sensor_site_id]
        return positions
