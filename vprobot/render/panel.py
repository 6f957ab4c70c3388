"""What the sensor itself sees, from the cell's `sensor_camera`: a colour image or a depth map."""

from __future__ import annotations

from typing import Literal, get_args

import mujoco
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.config.sensor import SensorModel
from vprobot.render.offscreen import OffscreenView
from vprobot.robots.description import SENSOR_CAMERA

PanelMode = Literal["color", "depth"]
NO_RETURN_RGB = np.array([25, 25, 30], dtype=np.uint8)
"""Depth pixels outside the sensor's range: the sensor gets nothing back there."""
NEAR_RGB = np.array([255, 230, 90], dtype=float)
FAR_RGB = np.array([60, 40, 160], dtype=float)


class SensorPanel:
    """Renders the sensor's view at the sensor's aspect ratio.

    Args:
        cell: The cell (its model has the sensor camera).
        width: Panel width in pixels; the height follows from the sensor's opening angles.
        mode: `color`, or `depth` (near yellow to far violet, dark outside the working range).

    Raises:
        ValueError: For an unknown mode or a bad size.
    """

    def __init__(self, cell: Cell, width: int, mode: PanelMode = "color"):
        if mode not in get_args(PanelMode):
            raise ValueError(f"sensor panel mode must be one of {get_args(PanelMode)}, "
                             f"got {mode!r}")
        sensor = SensorModel.from_config(cell.config.sensor)
        half_x, half_y = sensor.half_tangents
        height = max(1, round(width * half_y / half_x))
        self.mode = mode
        self.sensor = sensor
        self.view = OffscreenView(cell.model, width, height)
        self.view.use_fixed_camera(SENSOR_CAMERA)
        # The camera's vertical opening follows the configured sensor, not the model's default.
        self.view.model.cam_fovy[self.view.camera.fixedcamid] = sensor.fov_deg[1]

    @property
    def width(self) -> int:
        return self.view.width

    @property
    def height(self) -> int:
        return self.view.height

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The sensor's view at the robot configuration in `data`, as RGB (h, w, 3) uint8."""
        self.view.update(data)
        if self.mode == "color":
            return self.view.rgb()
        return self.colorize(self.view.depth())

    def colorize(self, depth: np.ndarray) -> np.ndarray:
        """Depth (m) to colour: near bound yellow, far bound violet, outside the range dark."""
        near, far = self.sensor.near_m, self.sensor.far_m
        fraction = (depth - near) / (far - near)
        inside = (fraction >= 0.0) & (fraction <= 1.0)
        rgb = NEAR_RGB + np.clip(fraction, 0.0, 1.0)[..., None] * (FAR_RGB - NEAR_RGB)
        return np.where(inside[..., None], rgb, NO_RETURN_RGB).astype(np.uint8)

    def close(self) -> None:
        self.view.close()
