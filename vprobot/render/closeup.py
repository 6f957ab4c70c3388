"""A close-up of the part alone, with its ground-truth points covered so far and not.

The overview of a cell frames the arm, so the part takes a tenth of the frame's height: too
little to tell covered surface from missed. The close-up looks at the part alone (the robot
hidden), from the overview's side, near enough that the part fills it; the video insets it.
"""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.episode import EpisodeRecord
from vprobot.render.camera import OVERVIEW_AZIMUTH_DEG, aim_at_sphere
from vprobot.render.markers import COVERED_RGBA, UNCOVERED_RGBA, add_points
from vprobot.render.offscreen import OffscreenView

FRAME_MARGIN = 1.1
"""The radius framed per metre of the part's radius."""
ELEVATION_DEG = -35.0
POINT_SIZE_M = 0.0025


def hide_robot(view: OffscreenView, cell: Cell) -> None:
    """Hide the robot (it would stand in front of the object) and the sites of `view`."""
    # MuJoCo skips fully transparent geoms; the robot's geom group is not the only one it uses.
    view.model.geom_rgba[cell.robot_geom_ids, 3] = 0.0
    view.option.sitegroup[:] = 0


def draw_coverage(scene: mujoco.MjvScene, record: EpisodeRecord, size_m: float,
                  views: int | None = None) -> None:
    """The ground-truth points of `record`, green where one of its first `views` views (all
    when None) covered them, red elsewhere."""
    first = record.first_covered_by
    covered = record.covered.astype(bool) if views is None else (first >= 0) & (first < views)
    add_points(scene, record.gt_points_world[covered], COVERED_RGBA, size_m)
    add_points(scene, record.gt_points_world[~covered], UNCOVERED_RGBA, size_m)


class PartCloseUp:
    """Square pictures of the part with its coverage after each count of views.

    Args:
        cell: The cell the episode ran in.
        data: Its data with the object placed as in the episode.
        record: The episode.
        size: Width and height in pixels.
    """

    def __init__(self, cell: Cell, data: mujoco.MjData, record: EpisodeRecord, size: int):
        self.data = data
        self.record = record
        self.view = OffscreenView(cell.model, size, size, fine=True,
                                  max_geom=len(record.gt_points_world))
        hide_robot(self.view, cell)
        radius = float(np.max(np.linalg.norm(cell.object_vertices, axis=1)))
        aim_at_sphere(self.view.camera, self.view.model, record.object_pose.position,
                      FRAME_MARGIN * radius, OVERVIEW_AZIMUTH_DEG, ELEVATION_DEG)
        self._pictures: dict[int, np.ndarray] = {}

    def render(self, views: int) -> np.ndarray:
        """The part with the coverage of the first `views` views (rendered once per count:
        neither the part nor its points move)."""
        if views not in self._pictures:
            self.view.update(self.data, lambda scene: draw_coverage(
                scene, self.record, POINT_SIZE_M, views))
            self._pictures[views] = self.view.rgb()
        return self._pictures[views]

    def close(self) -> None:
        self.view.close()
