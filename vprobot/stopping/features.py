"""What a real cell knows after each view, as features for the coverage estimate.

Model-free: the features read only what the sensor acquired (its poses, points, the pixels they
were measured on and the pixels the cell blocked), the number of views asked for, and the cell
(where an object may stand, the view band); never the mesh, the ground truth or the coverage
(`tests/test_model_free.py` guards it). The acquisitions are integrated into the occupancy grid
of the `nbv` planner (`vprobot.occupancy`), one frame at a time. After each view:

- `requested`, `acquired`: views asked for (the initial view included) and views acquired;
- `occupied`, `free`, `unknown`: each state's share of the grid's voxels;
- `rear_side`: unknown voxels next to an occupied one, per occupied voxel (behind or beside a
  seen surface: what may still hide surface, and the object's inside);
- `open_surface`: unknown voxels next to both an occupied and a free one, per occupied voxel
  (where a seen surface runs into unexplored space, unlike the closed inside);
- `extent`: the diagonal of the box that bounds the occupied voxels (m; 0 before any);
- `hull_unknown`: unknown voxels inside that box, per occupied voxel (the part of the seen
  object's extent not explored yet);
- `added_last`, `added_before`: the share of the occupied voxels the latest acquisition and the
  one before added (what the `grid` rule stops on; 1 before there was one);
- `novel_last`: the share of the latest acquisition's hit voxels that were not occupied before;
- `points`, `points_last`: acquired points per sensor pixel, over all frames and in the latest;
- `blocked`, `blocked_last`: blocked pixels per sensor pixel, mean over frames and the latest;
- `spread`: one minus the length of the mean direction from the cell's centre to the sensor
  over the acquisitions (0: all from one side);
- `band_seen`: the share of the band candidates' directions (`views.band_directions`)
  within `BAND_NEAR_DEG` of an acquisition's direction.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vprobot.config import Config
from vprobot.episode import ViewRecord
from vprobot.occupancy import FREE, OCCUPIED, UNKNOWN, VOXEL_M, OccupancyGrid
from vprobot.sensor_model import SensorModel
from vprobot.views import band_directions

FEATURES = ("requested", "acquired", "occupied", "free", "unknown", "rear_side", "open_surface",
            "extent", "hull_unknown", "added_last", "added_before", "novel_last", "points",
            "points_last", "blocked", "blocked_last", "spread", "band_seen")
"""The features in the order of a feature vector (see the module docstring)."""
BAND_NEAR_DEG = 45.0


class CoverageFeatures:
    """The features of an episode's views, updated view by view.

    Args:
        config: The cell (grid, view band) and the sensor (rays per frame, range).
        voxel_m: Voxel edge of the grid.
    """

    def __init__(self, config: Config, voxel_m: float = VOXEL_M):
        self.config = config
        self.voxel_m = voxel_m
        self.sensor = SensorModel.from_config(config.sensor)
        self.center = np.asarray(config.cell.object_center_m, dtype=float)
        self._band = band_directions()
        self.reset()

    def reset(self) -> None:
        """A new episode: an all-unknown grid, nothing integrated."""
        self.grid = OccupancyGrid.for_cell(self.config, self.voxel_m)
        self._seen = 0
        self._added = [1.0, 1.0]
        self._novel = 1.0
        self._points: list[int] = []
        self._blocked: list[int] = []
        self._directions: list[np.ndarray] = []

    def update(self, views: Sequence[ViewRecord]) -> np.ndarray:
        """Integrate the views not seen yet and return the features after the last one.

        Args:
            views: The episode's views so far (those seen before first, in order).

        Raises:
            ValueError: If `views` is shorter than what was integrated already.
        """
        if len(views) < self._seen:
            raise ValueError(f"{len(views)} views given after {self._seen} were integrated; "
                             f"call reset() for a new episode")
        for view in views[self._seen:]:
            if view.acquired:
                self._integrate(view)
        self._seen = len(views)
        return self._features()

    def _integrate(self, view: ViewRecord) -> None:
        pose = view.sensor_pose
        assert pose is not None  # an acquired view has a pose
        flat = self.grid.state.reshape(-1)
        hits = np.unique(self.grid.flat_index(np.asarray(view.points_world).reshape(-1, 3)))
        hits = hits[hits >= 0]
        before = self.grid.counts()["occupied"]
        novel = int((flat[hits] != OCCUPIED).sum())
        self.grid.integrate(self.sensor, pose, view.points_world, view.pixels,
                            view.blocked_pixels)
        after = self.grid.counts()["occupied"]
        self._added = [self._added[1], (after - before) / max(after, 1)]
        self._novel = novel / max(len(hits), 1)
        self._points.append(len(view.points_world))
        self._blocked.append(len(view.blocked_pixels))
        offset = pose.position - self.center
        self._directions.append(offset / max(float(np.linalg.norm(offset)), 1e-12))

    def _features(self) -> np.ndarray:
        grid = self.grid
        counts = grid.counts()
        total = grid.state.size
        occupied = max(counts["occupied"], 1)
        unknown = grid.state == UNKNOWN
        near_occupied = grid.next_to(OCCUPIED)
        rear_side = int((unknown & near_occupied).sum())
        open_surface = int((unknown & near_occupied & grid.next_to(FREE)).sum())
        cells = np.argwhere(grid.state == OCCUPIED)
        if len(cells):
            low, high = cells.min(axis=0), cells.max(axis=0) + 1
            extent = grid.voxel_m * float(np.linalg.norm(high - low))
            hull = unknown[low[0]:high[0], low[1]:high[1], low[2]:high[2]]
            hull_unknown = int(hull.sum())
        else:
            extent, hull_unknown = 0.0, 0
        pixels = self.sensor.rays_per_frame
        acquired = len(self._points)
        if acquired:
            directions = np.array(self._directions)
            spread = 1.0 - float(np.linalg.norm(directions.mean(axis=0)))
            near = (self._band @ directions.T).max(axis=1) >= np.cos(np.deg2rad(BAND_NEAR_DEG))
            band_seen = float(near.mean())
        else:
            spread = band_seen = 0.0
        values = {
            "requested": float(self._seen),
            "acquired": float(acquired),
            "occupied": counts["occupied"] / total,
            "free": counts["free"] / total,
            "unknown": counts["unknown"] / total,
            "rear_side": rear_side / occupied,
            "open_surface": open_surface / occupied,
            "extent": extent,
            "hull_unknown": hull_unknown / occupied,
            "added_last": self._added[1],
            "added_before": self._added[0],
            "novel_last": self._novel,
            "points": sum(self._points) / pixels,
            "points_last": self._points[-1] / pixels if acquired else 0.0,
            "blocked": sum(self._blocked) / pixels / max(acquired, 1),
            "blocked_last": self._blocked[-1] / pixels if acquired else 0.0,
            "spread": spread,
            "band_seen": band_seen,
        }
        return np.array([values[name] for name in FEATURES])


def episode_features(config: Config, views: Sequence[ViewRecord]) -> np.ndarray:
    """The features after each view of an episode (len(views), len(FEATURES))."""
    features = CoverageFeatures(config)
    return np.array([features.update(views[:count]) for count in range(1, len(views) + 1)]
                    ).reshape(len(views), len(FEATURES))
