"""Forward kinematics: joint configuration -> sensor (and flange) pose in the world."""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.geometry import Pose
from vprobot.scene import Cell


class ForwardKinematics:
    """Evaluates frame poses of the cell's robot on a private MjData.

    Args:
        cell: The compiled cell.
        data: The MjData to use (shared with the collision checker so that both see the same
            object placement); a fresh one when omitted.
    """

    def __init__(self, cell: Cell, data: mujoco.MjData | None = None):
        self.cell = cell
        self.data = data if data is not None else cell.make_data()

    def set_configuration(self, q: np.ndarray) -> None:
        """Move the robot to `q` and update all frames."""
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.cell.model, self.data)

    def sensor_pose(self, q: np.ndarray) -> Pose:
        """Pose of the sensor frame (+z viewing direction) in the world at `q`."""
        q = self.cell.joints.check(q)
        self.set_configuration(q)
        return self.current_sensor_pose()

    def current_sensor_pose(self) -> Pose:
        site = self.cell.sensor_site_id
        return Pose(
            self.data.site_xpos[site].copy(), self.data.site_xmat[site].reshape(3, 3).copy()
        )

    def flange_pose(self, q: np.ndarray) -> Pose:
        """Pose of the flange frame (`tool0`) in the world at `q`."""
        self.set_configuration(self.cell.joints.check(q))
        body = self.cell.flange_body_id
        return Pose(
            self.data.xpos[body].copy(), self.data.xmat[body].reshape(3, 3).copy()
        )

    def sensor_positions(self, configurations: np.ndarray) -> np.ndarray:
        """Sensor positions (n, 3) along a sequence of configurations (n, dof)."""
        positions = np.empty((len(configurations), 3))
        for index, q in enumerate(configurations):
            self.set_configuration(q)
            positions[index] = self.data.site_xpos[self.cell.sensor_site_id]
        return positions
