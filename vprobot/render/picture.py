"""A still picture of the cell, to compare with the real one (docs/your-cell.md#verify-it).

The robot stands at its start pose with the part placed, seen from the videos' front-left
overview and from above. The cell's static objects are drawn see-through: a guard wall or a
table in front of the camera must not hide the robot and the part.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from vprobot.cell.scene import STATIC_PREFIX, Cell
from vprobot.episode import EpisodeRecord, PartScene
from vprobot.render.camera import aim_overview
from vprobot.render.offscreen import OffscreenView, check_size
from vprobot.render.output import check_output_path, write_png
from vprobot.render.video import cell_of

STATIC_ALPHA = 0.35
"""Opacity of the static objects in the picture: visible, and the robot behind them too."""
TOP_ELEVATION_DEG = -89.0
"""The second panel looks straight down (MuJoCo's free camera turns about -90 exactly)."""


def render_cell_picture(scene: PartScene | Cell, record: EpisodeRecord, out_png: str | Path,
                        width: int = 1280, height: int = 480) -> Path:
    """Write a PNG of the cell: the robot at its start pose, the part as `record` placed it,
    from the front left (left half) and from above (right half).

    Raises:
        ValueError: For a bad output path or a size too small for two panels.
    """
    out_png = check_output_path(out_png, (".png",))
    width, height = check_size(width, height)
    panel_width = width // 2
    check_size(panel_width, height)
    cell = cell_of(scene)
    data = cell.make_data()
    cell.place_object(data, record.object_pose.rotation)
    data.qpos[:] = cell.joints.start
    mujoco.mj_kinematics(cell.model, data)
    panels = []
    with OffscreenView(cell.model, panel_width, height, fine=True) as view:
        statics = [geom for geom in range(view.model.ngeom)
                   if view.model.geom(geom).name.startswith(STATIC_PREFIX)]
        view.model.geom_rgba[statics, 3] = STATIC_ALPHA
        for elevation in (None, TOP_ELEVATION_DEG):
            aim_overview(view.camera, cell)
            if elevation is not None:
                view.camera.elevation = elevation
            view.update(data)
            panels.append(view.rgb())
    return write_png(out_png, np.concatenate(panels, axis=1))
