"""What a real cell knows after each view, as features for the coverage estimate.

Model-free: the features read only what the sensor acquired (its poses, points, the pixels they
were measured on and the pixels the cell blocked), the number of views asked for, and the cell
(where an object may stand, the view band); never the mesh, the ground truth or the coverage
(`tests/test_model_free.py` guards it). The acquisitions are integrated into the occupancy grid
of the `nbv` planner (`vprobot.coverage.occupancy`), one frame at a time; in an episode that is the
episode's own grid (`Episode.occupancy`), integrated once for every reader. After each view:

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
from vprobot.coverage.occupancy import (
    FREE,
    OCCUPIED,
    UNKNOWN,
    VOXEL_M,
    EpisodeGrid,
    GridSettings,
    OccupancyGrid,
)
from vprobot.episode import Episode, ViewRecord
from vprobot.episode.views import band_directions

FEATURES = ("requested", "acquired", "occupied", "free", "unknown", "rear_side", "open_surface",
            "extent", "hull_unknown", "added_last", "added_before", "novel_last", "points",
            "points_last", "blocked", "blocked_last", "spread", "band_seen")
"""The features in the order of a feature vector (see the module docstring)."""
BAND_NEAR_DEG = 45.0


class CoverageFeatures:
    """The features of an episode's views, view by view, read from the episode's grid.

    Args:
        config: The cell (grid, view band) and the sensor (rays per frame, range).
        voxel_m: Voxel edge of the grid.

    Attributes:
        settings: The settings of the grid the features read (`Episode.occupancy`).
        episode_grid: The grid of the current episode: the episode's own (`reset`), or one the
            views given to `update` are integrated into.
    """

    def __init__(self, config: Config, voxel_m: float = VOXEL_M):
        self.settings = GridSettings.of(config, voxel_m=voxel_m)
        self.sensor = self.settings.sensor
        self.center = np.array(self.settings.center)
        self._band = band_directions()
        self.reset()

    def reset(self, grid: EpisodeGrid | None = None) -> None:
        """A new episode, whose grid is `grid` (the episode's, of `settings`, shared with its
        other readers), or an all-unknown one of the features' own.

        Raises:
            ValueError: If `grid` is not of the features' settings.
        """
        if grid is not None and grid.settings != self.settings:
            raise ValueError("the episode's grid is not of the settings the features read")
        self.episode_grid = grid if grid is not None else EpisodeGrid(self.settings)
        self._seen = 0

    def read(self, episode: Episode) -> None:
        """Read the episode's grid of `settings` (`Episode.occupancy`, filled by whoever read it
        first): a new episode, unless it is the grid read already."""
        grid = episode.occupancy(self.settings)
        if grid is not self.episode_grid:
            self.reset(grid)

    @property
    def grid(self) -> OccupancyGrid:
        """The grid after every view integrated so far."""
        return self.episode_grid.grid

    def update(self, views: Sequence[ViewRecord]) -> np.ndarray:
        """Integrate the views not integrated yet and return the features after the last one.

        Args:
            views: The episode's views so far (those seen before first, in order).

        Raises:
            ValueError: If `views` is shorter than what was seen already.
        """
        if len(views) < self._seen:
            raise ValueError(f"{len(views)} views given after {self._seen} were integrated; "
                             f"call reset() for a new episode")
        self.episode_grid.update(views)
        self._seen = len(views)
        return self._features(views)

    def _features(self, views: Sequence[ViewRecord]) -> np.ndarray:
        """The features after `views`, the first views of the grid's episode."""
        grid = self.episode_grid.after(len(views))
        counts = grid.counts()
        total = grid.state.size
        occupied = max(counts["occupied"], 1)
        unknown = grid.state == UNKNOWN
        near_occupied = grid.next_to(OCCUPIED)
        rear_side = int((unknown & near_occupied).sum())
        open_surface = int((unknown & near_occupied & grid.next_to(FREE)).sum())
        box = grid.occupied_box()
        if box is not None:
            extent = grid.voxel_m * float(np.linalg.norm([span.stop - span.start
                                                          for span in box]))
            hull_unknown = int(unknown[box].sum())
        else:
            extent, hull_unknown = 0.0, 0
        frames = [(view, change) for view, change in
                  zip(views, self.episode_grid.changes[:len(views)], strict=True)
                  if change is not None]
        added = [1.0, 1.0, *(change.novel / max(change.occupied, 1) for _, change in frames)]
        pixels = self.sensor.rays_per_frame
        acquired = len(frames)
        points = [len(view.points_world) for view, _ in frames]
        blocked = [len(view.blocked_pixels) for view, _ in frames]
        if acquired:
            last, change = frames[-1]
            novel = change.novel / max(hit_voxels(grid, last.points_world), 1)
            directions = np.array([self._direction(view) for view, _ in frames])
            spread = 1.0 - float(np.linalg.norm(directions.mean(axis=0)))
            near = (self._band @ directions.T).max(axis=1) >= np.cos(np.deg2rad(BAND_NEAR_DEG))
            band_seen = float(near.mean())
        else:
            novel, spread, band_seen = 1.0, 0.0, 0.0
        values = {
            "requested": float(len(views)),
            "acquired": float(acquired),
            "occupied": counts["occupied"] / total,
            "free": counts["free"] / total,
            "unknown": counts["unknown"] / total,
            "rear_side": rear_side / occupied,
            "open_surface": open_surface / occupied,
            "extent": extent,
            "hull_unknown": hull_unknown / occupied,
            "added_last": added[-1],
            "added_before": added[-2],
            "novel_last": novel,
            "points": sum(points) / pixels,
            "points_last": points[-1] / pixels if acquired else 0.0,
            "blocked": sum(blocked) / pixels / max(acquired, 1),
            "blocked_last": blocked[-1] / pixels if acquired else 0.0,
            "spread": spread,
            "band_seen": band_seen,
        }
        return np.array([values[name] for name in FEATURES])

    def _direction(self, view: ViewRecord) -> np.ndarray:
        """Unit direction from the cell's centre to where an acquired view was taken from."""
        pose = view.sensor_pose
        assert pose is not None  # an acquired view has a pose
        offset = pose.position - self.center
        return offset / max(float(np.linalg.norm(offset)), 1e-12)


def hit_voxels(grid: OccupancyGrid, points_world: np.ndarray) -> int:
    """How many voxels of the grid hold one of the points."""
    index = grid.flat_index(np.asarray(points_world).reshape(-1, 3))
    hit = np.zeros(grid.state.size, dtype=bool)
    hit[index[index >= 0]] = True
    return int(np.count_nonzero(hit))


def episode_features(config: Config, views: Sequence[ViewRecord],
                     grid: EpisodeGrid | None = None) -> np.ndarray:
    """The features after each view of an episode (len(views), len(FEATURES)), read from the
    episode's grid (`Episode.occupancy` of `CoverageFeatures.settings`) or integrated here."""
    features = CoverageFeatures(config)
    features.reset(grid)
    return np.array([features.update(views[:count]) for count in range(1, len(views) + 1)]
                    ).reshape(len(views), len(FEATURES))
