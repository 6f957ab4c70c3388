"""A voxel occupancy grid built from acquired depth frames, and the gains of candidate views.

This is what a model-free planner knows about the object: the cell says where an object may
stand (a cube about the fixture's centre, as wide as the largest object the cell accepts,
`vprobot.cell.fit`); the sensor says what it measured. Every voxel starts `UNKNOWN`. A frame clears
the space its rays crossed (Delmerico et al., 2018):

- a ray that measured a point marks the voxels it crossed from the sensor's near bound up to
  the point `FREE`, and the voxel of the point `OCCUPIED`;
- a ray that measured nothing within the range marks its voxels from near to far `FREE`;
- voxels closer than the near bound are not observed (the sensor cannot tell), and an
  `OCCUPIED` voxel is never cleared again (a surface seen once stays).

A ray whose view of the object the robot or the cell (fixture, floor) blocked observes nothing:
a real cell sees the occluder and knows it as its own (a self filter), so it cannot tell what
lies behind. (The simulated sensor returns object points only; a ray that met an occluder with
no object behind it counts as one that measured nothing, which is true: that space is free.)

The rays are not walked voxel by voxel: each still-unknown voxel is projected into the frame
instead (projective integration, as depth fusion does). It is crossed when the ray through its
centre, or at a silhouette the ray through one of four points of its footprint, runs through it
for `CROSSING_SHARE` of a voxel or more between the near bound and half a voxel before what that
pixel measured; the voxel must reach that far into the frustum's side planes (by its box's
support) and begin half a voxel before the far bound. Only unknown voxels can change, so a frame
costs in proportion to the space still unknown: in the realistic cell's 85^3 grid about 48 ms
for an episode's first frame and 14 ms for the later ones (medians over the test lists). The
former integration, which sampled every ray of the frame half a voxel apart from near to far, is
the reference it is measured against (`vprobot benchmark grid`: the share of voxels classified
otherwise, and the time).

The gains of candidate views against the grid are `vprobot.coverage.view_gains`'s; `GAINS` names the
kinds of voxels they count (`OccupancyGrid.kind_mask`):

- `unknown`: unknown voxels (volumetric information, occlusion aware);
- `frontier`: unknown voxels next to a free one (the border of the explored space);
- `rear_side`: unknown voxels next to an occupied one (behind or beside seen surfaces).

A grid also keeps, per voxel, the directions its points were measured from
(`OccupancyGrid.measured_from`): one bit per direction of `DIRECTIONS` (a voxel's 26 neighbours),
the one nearest the direction from the voxel's centre to the camera of each frame that measured a
point in it. At a centimetre a voxel, an occupied voxel often holds surface that its first views
did not measure (an edge, a fillet, a bore's wall seen at a slant); what a view from another
direction would still measure there is `vprobot.coverage.view_gains`'s revisit gain.

`EpisodeGrid` keeps the grid of one episode, integrating each acquired frame once; the episode
owns it (`vprobot.episode.Episode.occupancy`), so that the `nbv` planner, the `s_grid` state, the
`grid` stop rule and the coverage estimate's features read one grid wherever their
`GridSettings` agree.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Literal, Protocol

import numpy as np

from vprobot.cell.fit import fit_limit
from vprobot.config import Config
from vprobot.config.sensor import SensorModel
from vprobot.geometry.poses import Pose

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
VOXEL_M = 0.01
"""Default voxel edge: 38^3 voxels over the default cell's 0.378 m cube."""
CROSSING_SHARE = 0.25
"""A ray crosses a voxel when it runs through it for a quarter of a voxel or more: where the
former integration, sampling every ray half a voxel apart, put a sample in it on average."""
Gain = Literal["unknown", "frontier", "rear_side"]
GAINS: tuple[Gain, ...] = ("unknown", "frontier", "rear_side")
NEIGHBOUR_OFFSETS = np.array([(dx, dy, dz) for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                              for dz in (-1, 0, 1) if (dx, dy, dz) != (0, 0, 0)])
"""The offsets to a voxel's 26 neighbours."""
DIRECTIONS = NEIGHBOUR_OFFSETS / np.linalg.norm(NEIGHBOUR_OFFSETS, axis=1, keepdims=True)
"""The directions a voxel's points are measured from, binned (`OccupancyGrid.measured_from`): to
its 26 neighbours, 35-55 degrees apart."""


def nearest_direction(directions: np.ndarray) -> np.ndarray:
    """The index of the nearest of `DIRECTIONS` to each direction (n, 3; any length)."""
    return np.argmax(np.asarray(directions, dtype=np.float32) @ DIRECTIONS.T.astype(np.float32),
                     axis=1)


def gain_kinds(state: np.ndarray, neighbours: np.ndarray) -> list[np.ndarray]:
    """Which voxels each gain of `GAINS` counts, in its order, from their states and their
    neighbours' (`OccupancyGrid.neighbours`): the unknown, those of them next to a free voxel
    (`frontier`) and those next to an occupied one (`rear_side`)."""
    unknown = state == UNKNOWN
    return [unknown, unknown & ((neighbours & (1 << FREE)) != 0),
            unknown & ((neighbours & (1 << OCCUPIED)) != 0)]


class MeasuredView(Protocol):
    """What the grid integrates of a view (the episode's `ViewRecord`, which sits above the grid:
    the episode keeps one)."""

    @property
    def sensor_pose(self) -> Pose | None: ...

    @property
    def points_world(self) -> np.ndarray: ...

    @property
    def pixels(self) -> np.ndarray: ...

    @property
    def blocked_pixels(self) -> np.ndarray: ...


@dataclasses.dataclass
class OccupancyGrid:
    """Voxels of an axis-aligned cube in the world, each `UNKNOWN`, `FREE` or `OCCUPIED`.

    Attributes:
        origin: The cube's lowest corner (world, m).
        voxel_m: Voxel edge (m).
        state: Voxel states (nx, ny, nz), int8.
        measured_from: Per voxel, a bit per direction of `DIRECTIONS` from which a frame
            measured a point in it (nx, ny, nz), uint32; zero where none did.
    """

    origin: np.ndarray
    voxel_m: float
    state: np.ndarray
    measured_from: np.ndarray

    @classmethod
    def around(cls, center: np.ndarray, half_size_m: float, voxel_m: float = VOXEL_M
               ) -> OccupancyGrid:
        """An all-unknown grid over the cube of half-edge `half_size_m` about `center`.

        Raises:
            ValueError: If the sizes are not positive or the voxel exceeds the cube.
        """
        if not (half_size_m > 0.0 and voxel_m > 0.0):
            raise ValueError(f"half_size_m and voxel_m must be positive, got {half_size_m!r} "
                             f"and {voxel_m!r}")
        if voxel_m > 2.0 * half_size_m:
            raise ValueError(f"voxel_m {voxel_m:g} exceeds the cube's edge {2 * half_size_m:g}")
        count = math.ceil(2.0 * half_size_m / voxel_m - 1e-9)
        half = count * voxel_m / 2.0
        return cls(np.asarray(center, dtype=float) - half, float(voxel_m),
                   np.full((count, count, count), UNKNOWN, dtype=np.int8),
                   np.zeros((count, count, count), dtype=np.uint32))

    @classmethod
    def for_cell(cls, config: Config, voxel_m: float = VOXEL_M) -> OccupancyGrid:
        """The grid over where an object may stand in the configured cell (not from a mesh)."""
        center, half_size_m = _cell_cube(config)
        return cls.around(np.array(center), half_size_m, voxel_m)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.state.shape

    def flat_index(self, points: np.ndarray) -> np.ndarray:
        """Flat voxel index of each point (..., 3); -1 outside the grid."""
        cells = np.subtract(points, self.origin)
        cells /= self.voxel_m
        np.floor(cells, out=cells)
        # Axis by axis, in floats (whole numbers, exact): a reduction over the last axis of
        # three and an index clipped for `ravel_multi_index` took most of a frame's
        # integration.
        flat = np.zeros(cells.shape[:-1])
        inside = np.ones(cells.shape[:-1], dtype=bool)
        for axis, size in enumerate(self.shape):
            cell = cells[..., axis]
            inside &= (cell >= 0) & (cell < size)
            flat *= size
            flat += cell
        return np.where(inside, flat, -1).astype(np.int64)

    def counts(self) -> dict[str, int]:
        """How many voxels are unknown, free and occupied."""
        values = np.bincount(self.state.ravel(), minlength=3)
        return {"unknown": int(values[UNKNOWN]), "free": int(values[FREE]),
                "occupied": int(values[OCCUPIED])}

    def neighbours(self) -> np.ndarray:
        """Per voxel, the states among its six face neighbours: bit `1 << state` set for each
        (uint8, grid shape)."""
        state = np.left_shift(np.uint8(1), self.state.view(np.uint8))
        near = np.zeros(self.shape, dtype=np.uint8)
        # Each axis both ways: in place, with no padded copy of the grid.
        near[1:] |= state[:-1]
        near[:-1] |= state[1:]
        near[:, 1:] |= state[:, :-1]
        near[:, :-1] |= state[:, 1:]
        near[:, :, 1:] |= state[:, :, :-1]
        near[:, :, :-1] |= state[:, :, 1:]
        return near

    def occupied_box(self) -> tuple[slice, slice, slice] | None:
        """The box of voxels that bounds the occupied ones, as slices of the grid; None before
        any is occupied."""
        occupied = self.state == OCCUPIED
        spans = [np.flatnonzero(occupied.any(axis=tuple(other for other in range(3)
                                                         if other != axis)))
                 for axis in range(3)]
        if not len(spans[0]):
            return None
        return (slice(spans[0][0], spans[0][-1] + 1), slice(spans[1][0], spans[1][-1] + 1),
                slice(spans[2][0], spans[2][-1] + 1))

    def next_to(self, kind: int) -> np.ndarray:
        """Whether each voxel has a face neighbour of state `kind` (bool, grid shape)."""
        return (self.neighbours() & (1 << kind)) != 0

    def kind_masks(self) -> list[np.ndarray]:
        """The voxels each gain of `GAINS` counts, in its order (bool, grid shape)."""
        return gain_kinds(self.state, self.neighbours())

    def kind_mask(self, gain: Gain) -> np.ndarray:
        """The voxels a gain counts (bool, grid shape)."""
        if gain not in GAINS:
            raise ValueError(f"unknown gain {gain!r}; allowed: {', '.join(GAINS)}")
        return self.kind_masks()[GAINS.index(gain)]

    @functools.cached_property
    def centres(self) -> np.ndarray:
        """The centre of every voxel (3, voxels), flat order, world, float32; read-only."""
        centres = self.centres_of(np.indices(self.shape).reshape(3, -1))
        centres.setflags(write=False)
        return centres

    def centres_of(self, cells: np.ndarray) -> np.ndarray:
        """The centres (3, n) of the voxels at integer cells (3, n), world, float32."""
        return (self.origin[:, None] + (cells.astype(np.float32) + 0.5) * self.voxel_m
                ).astype(np.float32)

    def integrate(self, sensor: SensorModel, pose: Pose, points_world: np.ndarray,
                  pixels: np.ndarray, blocked_pixels: np.ndarray | None = None) -> None:
        """Integrate one frame: the sensor's pose and the points it measured (world).

        Args:
            sensor: The sensor's ray grid and range.
            pose: The sensor pose the frame was taken from.
            points_world: The measured points (n, 3).
            pixels: The row-major pixel of each point (n,).
            blocked_pixels: Row-major pixels whose ray an occluder of the cell blocked.
        """
        width, height = sensor.resolution
        points_world = np.asarray(points_world, dtype=float).reshape(-1, 3)
        depth = np.full(height * width, np.inf, dtype=np.float32)
        # The norm summed axis by axis: what np.linalg.norm computes, at half its time.
        offsets = np.square(points_world - pose.position)
        np.minimum.at(depth, np.asarray(pixels, dtype=np.int64),
                      np.sqrt(offsets[:, 0] + offsets[:, 1] + offsets[:, 2]).astype(np.float32))
        if blocked_pixels is not None and len(blocked_pixels):
            depth[np.asarray(blocked_pixels, dtype=np.int64)] = -np.inf
        # Only an unknown voxel can change: free stays free, occupied stays occupied.
        unknown = np.flatnonzero(self.state.reshape(-1) == UNKNOWN)
        offset = np.take(self.centres, unknown, axis=1)
        offset -= pose.position.astype(np.float32)[:, None]
        x, y, z = pose.rotation.T.astype(np.float32) @ offset  # the sensor frame
        distance = np.sqrt(x * x + y * y + z * z)
        half = 0.5 * self.voxel_m
        least = CROSSING_SHARE * self.voxel_m
        # Half the chord of the ray through the voxel's centre (a box's support along the ray:
        # half a voxel times the ray's 1-norm, in the grid's axes).
        np.abs(offset, out=offset)
        reach = (offset[0] + offset[1] + offset[2]) * (half / distance)
        half_x, half_y = sensor.half_tangents
        # The range: at least `least` of the chord beyond the near bound, and the voxel begins
        # half a voxel before the far bound (the reference's last sample lay half a voxel short
        # of it).
        seen = ((z > 0.0) & (distance + reach - sensor.near_m >= least)
                & (sensor.far_m - distance + reach >= half))
        # The frustum's four side planes: the voxel reaches at least `least` into each.
        for axis, tangent in ((0, half_x), (1, half_y)):
            across = x if axis == 0 else y
            for sign in (1.0, -1.0):
                inward = np.zeros(3)
                inward[axis], inward[2] = -sign, tangent
                inward /= np.linalg.norm(inward)
                support = half * np.abs(pose.rotation @ inward).sum()
                seen &= (tangent * z - sign * across) / math.hypot(1.0, tangent) >= (
                    least - support)
        unknown, distance, reach = unknown[seen], distance[seen], reach[seen]
        x, y, z = x[seen], y[seen], z[seen]
        columns_per_tangent, rows_per_tangent = 0.5 * width / half_x, 0.5 * height / half_y
        column = (x / z + half_x) * columns_per_tangent
        row = (y / z + half_y) * rows_per_tangent
        # Along the ray through the centre, else (at a silhouette) through one of four points
        # of its footprint, the segment from the near bound to half a voxel before the
        # measurement crosses the voxel for at least `least`.
        begin = np.maximum(distance - reach, sensor.near_m)
        end = distance + reach
        footprint = np.maximum(reach - least, 0.0) / z
        crossed = np.zeros(len(unknown), dtype=bool)
        for du, dv in ((0.0, 0.0), (-1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (0.0, 1.0)):
            pixel = (np.clip(row + dv * footprint * rows_per_tangent, 0, height - 1)
                     .astype(np.int64) * width
                     + np.clip(column + du * footprint * columns_per_tangent, 0, width - 1)
                     .astype(np.int64))
            crossed |= np.minimum(depth[pixel] - half, end) - begin >= least
        flat = self.state.reshape(-1)
        flat[unknown[crossed]] = FREE
        hits = self.flat_index(points_world)
        flat[hits[hits >= 0]] = OCCUPIED
        # One direction per voxel and frame: across a voxel the camera's direction turns by
        # about a degree. Marks instead of sorting the hits.
        marked = np.zeros(flat.size + 1, dtype=bool)
        marked[hits] = True  # -1, outside the grid, marks the extra last element
        voxels = np.flatnonzero(marked[:-1])
        toward = pose.position.astype(np.float32)[:, None] - np.take(self.centres, voxels, axis=1)
        self.measured_from.reshape(-1)[voxels] |= np.left_shift(
            np.uint32(1), nearest_direction(toward.T).astype(np.uint32))


def _cell_cube(config: Config) -> tuple[tuple[float, float, float], float]:
    """Where a grid of the configured cell stands: the centre of the cube in which an object may
    stand (world, m) and half its edge (the largest object the cell accepts, `fit_limit`)."""
    x, y, z = (float(value) for value in config.cell.object_center_m)
    return (x, y, z), fit_limit(config).radius_m


@dataclasses.dataclass(frozen=True)
class GridSettings:
    """What an episode's grid depends on: where it stands, its voxel and the sensor whose frames
    it integrates. Readers of one episode that give equal settings share its grid
    (`vprobot.episode.Episode.occupancy`).

    Attributes:
        center: The centre of the grid's cube (world, m): where the cell places an object.
        half_size_m: Half the cube's edge: the largest object the cell accepts (`fit_limit`).
        voxel_m: Voxel edge (m).
        sensor: The ray grid and range of the episode's frames.
    """

    center: tuple[float, float, float]
    half_size_m: float
    voxel_m: float
    sensor: SensorModel

    @classmethod
    def of(cls, config: Config, resolution: tuple[int, int] | None = None,
           voxel_m: float = VOXEL_M) -> GridSettings:
        """The settings of the configured cell and sensor (at `resolution`: the frames', None
        for the configured sensor's) with voxels of `voxel_m`."""
        sensor = SensorModel.from_config(config.sensor)
        return cls(*_cell_cube(config), voxel_m,
                   sensor if resolution is None else sensor.at_resolution(resolution))

    def new_grid(self) -> OccupancyGrid:
        """An all-unknown grid of these settings (`OccupancyGrid.for_cell` of the config)."""
        return OccupancyGrid.around(np.array(self.center), self.half_size_m, self.voxel_m)


@dataclasses.dataclass(frozen=True)
class FrameChange:
    """What integrating one acquired frame changed in an episode's grid.

    Attributes:
        changed: Flat indices of the voxels whose state it changed.
        previous: Their states before it (int8).
        redirected: Flat indices of the voxels it measured from a new direction.
        previous_from: Their `measured_from` before it (uint32).
        novel: Voxels it made occupied: its points' voxels that were not occupied before.
        occupied: Occupied voxels after it.
        informative: Whether the cell did not mostly hide it (fewer blocked pixels than
            points).
    """

    changed: np.ndarray
    previous: np.ndarray
    redirected: np.ndarray
    previous_from: np.ndarray
    novel: int
    occupied: int
    informative: bool


class EpisodeGrid:
    """The occupancy grid of one episode, integrating each acquired frame of it once and
    keeping what each changed, so that the grid after any of its views can be read back.

    Args:
        settings: Where the grid stands, its voxel and the sensor of the frames.

    Attributes:
        grid: The grid of the frames integrated so far.
        changes: Per view integrated so far, what its frame changed (None: none acquired).
    """

    def __init__(self, settings: GridSettings):
        self.settings = settings
        self.grid = settings.new_grid()
        self.changes: list[FrameChange | None] = []
        self._counts = np.bincount(self.grid.state.reshape(-1), minlength=3)

    def counts(self) -> dict[str, int]:
        """`grid.counts()`, kept frame by frame from what each frame changed (no pass over the
        grid)."""
        return {"unknown": int(self._counts[UNKNOWN]), "free": int(self._counts[FREE]),
                "occupied": int(self._counts[OCCUPIED])}

    @property
    def added(self) -> list[float]:
        """Per informative frame (one the cell did not mostly hide: it says nothing about what
        is left), the share of the occupied voxels it added."""
        return [change.novel / max(change.occupied, 1) for change in self.changes
                if change is not None and change.informative]

    def update(self, views: Sequence[MeasuredView]) -> None:
        """Integrate the frames of the views not integrated yet (the episode's views so far)."""
        flat = self.grid.state.reshape(-1)
        directions = self.grid.measured_from.reshape(-1)
        for view in views[len(self.changes):]:
            if view.sensor_pose is None:
                self.changes.append(None)
                continue
            before, before_from = flat.copy(), directions.copy()
            self.grid.integrate(self.settings.sensor, view.sensor_pose, view.points_world,
                                view.pixels, view.blocked_pixels)
            changed = np.flatnonzero(before != flat)
            previous, now = before[changed], flat[changed]
            redirected = np.flatnonzero(before_from != directions)
            self._counts += np.bincount(now, minlength=3) - np.bincount(previous, minlength=3)
            # Only a frame's own points turn voxels occupied, and none is ever cleared.
            self.changes.append(FrameChange(
                changed, previous, redirected, before_from[redirected],
                int(np.count_nonzero(now == OCCUPIED)),
                int(self._counts[OCCUPIED]), len(view.blocked_pixels) < len(view.points_world)))

    def after(self, count: int) -> OccupancyGrid:
        """The grid after the first `count` views integrated (the grid itself after all).

        Raises:
            ValueError: If fewer than `count` views were integrated.
        """
        if not 0 <= count <= len(self.changes):
            raise ValueError(f"the grid after {count} views was asked for; {len(self.changes)} "
                             f"were integrated")
        if count == len(self.changes):
            return self.grid
        state, measured_from = self.grid.state.copy(), self.grid.measured_from.copy()
        flat, directions = state.reshape(-1), measured_from.reshape(-1)
        for change in reversed(self.changes[count:]):
            if change is not None:
                flat[change.changed] = change.previous
                directions[change.redirected] = change.previous_from
        return dataclasses.replace(self.grid, state=state, measured_from=measured_from)
