"""A voxel occupancy grid built from acquired depth frames, and the gains of candidate views.

This is what a model-free planner knows about the object: the cell says where an object may
stand (a cube about the fixture's centre, as wide as the largest object the cell accepts,
`vprobot.fit`); the sensor says what it measured. Every voxel starts `UNKNOWN`. A frame is
integrated ray by ray (Delmerico et al., 2018):

- a ray that measured a point marks the voxels it crossed from the sensor's near bound up to
  the point `FREE`, and the voxel of the point `OCCUPIED`;
- a ray that measured nothing within the range marks its voxels from near to far `FREE`;
- voxels closer than the near bound are not observed (the sensor cannot tell), and an
  `OCCUPIED` voxel is never cleared again (a surface seen once stays).

A ray whose view of the object the robot or the cell (fixture, floor) blocked observes nothing:
a real cell sees the occluder and knows it as its own (a self filter), so it cannot tell what
lies behind. (The simulated sensor returns object points only; a ray that met an occluder with
no object behind it counts as one that measured nothing, which is true: that space is free.)
Rays are integrated in blocks of `stride` x `stride` pixels (one ray per block, as long as the
block's nearest measurement; none for a block with a blocked pixel), fine enough that
neighbouring rays are less than half a voxel apart at the far bound.

A candidate view is scored by casting a sparse grid of rays through the grid (`ViewGains`):
along each ray a sample's visibility is the product of the chances that the samples before it
let the ray through (1 for free, `UNKNOWN_PASS` per voxel for unknown, 0 for occupied), and a
gain sums the visibility of the samples of one kind:

- `unknown`: unknown voxels (volumetric information, occlusion aware);
- `frontier`: unknown voxels next to a free one (the border of the explored space);
- `rear_side`: unknown voxels next to an occupied one (behind or beside seen surfaces).

`EpisodeGrid` keeps the grid of one episode, integrating each acquired frame once; the episode
owns it (`vprobot.episode.Episode.occupancy`), so that the `nbv` planner, the `s_grid` state, the
`grid` stop rule and the coverage estimate's features read one grid wherever their
`GridSettings` agree.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import numpy as np

from vprobot.config import Config
from vprobot.fit import fit_limit
from vprobot.geometry import Pose
from vprobot.sensor_model import SensorModel

if TYPE_CHECKING:
    from vprobot.episode import ViewRecord

UNKNOWN, FREE, OCCUPIED = 0, 1, 2
VOXEL_M = 0.01
"""Default voxel edge: 38^3 voxels over the default cell's 0.378 m cube."""
UNKNOWN_PASS = 0.5
"""Chance that a ray passes an unknown voxel (an uninformed prior: as likely free as not)."""
Gain = Literal["unknown", "frontier", "rear_side"]
GAINS: tuple[Gain, ...] = ("unknown", "frontier", "rear_side")
_NEIGHBOURS = np.concatenate([np.eye(3, dtype=int), -np.eye(3, dtype=int)])
_KIND_BITS = len(GAINS)
_CODES = (OCCUPIED + 1) << _KIND_BITS
_RAYS_PER_BLOCK = 256
"""Rays integrated at once: their samples take a few megabytes."""


@dataclasses.dataclass
class OccupancyGrid:
    """Voxels of an axis-aligned cube in the world, each `UNKNOWN`, `FREE` or `OCCUPIED`.

    Attributes:
        origin: The cube's lowest corner (world, m).
        voxel_m: Voxel edge (m).
        state: Voxel states (nx, ny, nz), int8.
    """

    origin: np.ndarray
    voxel_m: float
    state: np.ndarray

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
                   np.full((count, count, count), UNKNOWN, dtype=np.int8))

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

    def next_to(self, kind: int) -> np.ndarray:
        """Whether each voxel has a face neighbour of state `kind` (bool, grid shape)."""
        padded = np.pad(self.state == kind, 1)
        near = np.zeros(self.shape, dtype=bool)
        nx, ny, nz = self.shape
        for dx, dy, dz in _NEIGHBOURS:
            near |= padded[1 + dx:1 + dx + nx, 1 + dy:1 + dy + ny, 1 + dz:1 + dz + nz]
        return near

    def kind_mask(self, gain: Gain) -> np.ndarray:
        """The voxels a gain counts (bool, grid shape)."""
        unknown = self.state == UNKNOWN
        if gain == "unknown":
            return unknown
        if gain == "frontier":
            return unknown & self.next_to(FREE)
        if gain == "rear_side":
            return unknown & self.next_to(OCCUPIED)
        raise ValueError(f"unknown gain {gain!r}; allowed: {', '.join(GAINS)}")

    def integrate(self, sensor: SensorModel, pose: Pose, points_world: np.ndarray,
                  pixels: np.ndarray, blocked_pixels: np.ndarray | None = None,
                  stride: int | None = None) -> None:
        """Integrate one frame: the sensor's pose and the points it measured (world).

        Args:
            sensor: The sensor's ray grid and range.
            pose: The sensor pose the frame was taken from.
            points_world: The measured points (n, 3).
            pixels: The row-major pixel of each point (n,).
            blocked_pixels: Row-major pixels whose ray an occluder of the cell blocked.
            stride: Pixels per block edge (one ray per block); by default the largest that
                keeps neighbouring rays within half a voxel at the far bound.
        """
        width, height = sensor.resolution
        if stride is None:
            pixel_at_far = 2.0 * sensor.far_m * sensor.half_tangents[0] / width
            stride = max(1, int(0.5 * self.voxel_m / pixel_at_far))
        points_world = np.asarray(points_world, dtype=float).reshape(-1, 3)
        depth = np.full(height * width, np.inf)
        # The norm summed axis by axis: what np.linalg.norm computes, at half its time.
        offsets = np.square(points_world - pose.position)
        np.minimum.at(depth, np.asarray(pixels, dtype=np.int64),
                      np.sqrt(offsets[:, 0] + offsets[:, 1] + offsets[:, 2]))
        if blocked_pixels is not None and len(blocked_pixels):
            depth[np.asarray(blocked_pixels, dtype=np.int64)] = -np.inf
        blocks_y, blocks_x = -(-height // stride), -(-width // stride)
        padded = np.full((blocks_y * stride, blocks_x * stride), np.inf)
        padded[:height, :width] = depth.reshape(height, width)
        nearest = padded.reshape(blocks_y, stride, blocks_x, stride).min(axis=(1, 3)).ravel()
        u, v = sensor.pixel_tangents
        centre_u = u[np.minimum(np.arange(blocks_x) * stride + stride // 2, width - 1)]
        centre_v = v[np.minimum(np.arange(blocks_y) * stride + stride // 2, height - 1)]
        grid_u, grid_v = np.meshgrid(centre_u, centre_v)
        rays = np.stack([grid_u.ravel(), grid_v.ravel(), np.ones(grid_u.size)], axis=1)
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        # Free space stops half a voxel short of a measurement, so that the measured surface's
        # own voxel is never crossed.
        length = np.where(np.isposinf(nearest), sensor.far_m, nearest - 0.5 * self.voxel_m)
        distances = sample_distances(sensor, self.voxel_m)
        world = rays @ pose.rotation.T
        flat = self.state.reshape(-1)
        # Block by block of rays, each only as far as its longest ray goes: the whole frame's
        # samples at once (a long-range sensor's, pixel by pixel) took gigabytes and most of the
        # time in allocating them.
        for start in range(0, len(world), _RAYS_PER_BLOCK):
            block = slice(start, start + _RAYS_PER_BLOCK)
            reach = np.searchsorted(distances, length[block].max(), side="right")
            samples = world[block, None, :] * distances[None, :reach, None]
            samples += pose.position
            index = self.flat_index(samples)
            crossed = (distances[None, :reach] <= length[block, None]) & (index >= 0)
            cleared = index[crossed]
            flat[cleared[flat[cleared] != OCCUPIED]] = FREE
        hits = self.flat_index(points_world)
        flat[hits[hits >= 0]] = OCCUPIED


def sample_distances(sensor: SensorModel, voxel_m: float) -> np.ndarray:
    """Distances half a voxel apart from the sensor's near to its far bound."""
    step = 0.5 * voxel_m
    return np.arange(sensor.near_m, sensor.far_m + step, step)


def ray_samples(pose: Pose, directions: np.ndarray, sensor: SensorModel,
                voxel_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples half a voxel apart along rays from the sensor's near to its far bound.

    Args:
        pose: The sensor pose.
        directions: Unit ray directions (n, 3) in the sensor frame.
        sensor: The sensor's range.
        voxel_m: Voxel edge of the grid the samples are for.

    Returns:
        The distances along every ray (k,) and the sample points (n, k, 3) in the world.
    """
    distances = sample_distances(sensor, voxel_m)
    return distances, (pose.position + (directions @ pose.rotation.T)[:, None, :]
                       * distances[None, :, None])


class ViewGains:
    """Gains of a fixed set of candidate sensor poses, scored against a grid.

    The rays of every candidate are sampled once (their voxel indices do not depend on what the
    grid holds), so that scoring all candidates is a gather and a cumulative product.

    Args:
        grid: The grid the candidates will be scored against (its geometry only).
        sensor: The sensor's opening angles and range.
        poses: Candidate sensor poses (world).
        rays: Rays per candidate along image x and y.
    """

    def __init__(self, grid: OccupancyGrid, sensor: SensorModel, poses: list[Pose],
                 rays: tuple[int, int] = (16, 12)):
        directions = sensor.at_resolution(rays).ray_directions
        index = grid.flat_index(np.stack([ray_samples(pose, directions, sensor, grid.voxel_m)[1]
                                          for pose in poses]))
        # Samples outside the grid read an extra last element that counts as free space.
        self._index = np.where(index >= 0, index, grid.state.size).astype(np.int32)
        # Two samples per voxel: each passes an unknown voxel with the root of its chance.
        self._unknown_pass = UNKNOWN_PASS ** 0.5
        self._runs = _SampleRuns(self._index, grid.state.size, self._unknown_pass)

    def __len__(self) -> int:
        return len(self._index)

    @property
    def rays(self) -> int:
        """Rays per candidate."""
        return self._index.shape[1]

    @property
    def ray_bound(self) -> float:
        """The largest gain of one ray: every sample unknown, inside the grid and counted."""
        samples = self._index.shape[2]
        return (1.0 - self._unknown_pass ** samples) / (1.0 - self._unknown_pass)

    @staticmethod
    def _seen(passes: np.ndarray) -> np.ndarray:
        """Visibility of every sample: everything before it let the ray through (its own
        state aside)."""
        visible = np.cumprod(passes, axis=-1)
        return np.concatenate([np.ones_like(visible[..., :1]), visible[..., :-1]], axis=-1)

    def score(self, grid: OccupancyGrid, gain: Gain) -> np.ndarray:
        """The gain of every candidate (count,) against the grid's current state."""
        state = np.append(grid.state.reshape(-1), np.int8(FREE))[self._index]
        passes = np.where(state == FREE, 1.0,
                          np.where(state == UNKNOWN, self._unknown_pass, 0.0))
        counted = np.append(grid.kind_mask(gain).reshape(-1), False)[self._index]
        return (self._seen(passes) * counted).sum(axis=(1, 2))

    def scores(self, grid: OccupancyGrid) -> np.ndarray:
        """Every gain of every candidate (count, len(GAINS)): `score` of each gain, computed
        over the runs of samples in one voxel (for the environment's state, where speed
        counts)."""
        code = grid.state.astype(np.uint8) << _KIND_BITS
        for bit, gain in enumerate(GAINS):
            code |= grid.kind_mask(gain).astype(np.uint8) << bit
        return self._runs.scores(np.append(code.reshape(-1), np.uint8(FREE << _KIND_BITS)))


class _SampleRuns:
    """The samples of every ray as runs of consecutive samples in one voxel, for `scores`.

    Half a voxel apart, a ray's samples fall in the same voxel up to four times in a row (the
    band candidates' runs number about 60 % of their samples); a run of m samples passes a ray
    with the m-th power of one sample's chance and its samples' visibility sums to the first
    one's times 1 + p + ... + p^(m-1). The runs are stored run by run across all rays (run,
    ray), so that the cumulative product is a few dozen products of whole rows, and every ray
    starts with an empty run (visibility 1 before the first voxel). What a run reads is one
    byte, its key: length x `_CODES` + its voxel's code (state << 3 | one bit per gain).

    Args:
        index: Voxel index of every sample (candidates, rays, samples); `outside` for samples
            outside the grid.
        outside: The index of the extra element read outside the grid (free space).
        unknown_pass: One sample's chance to pass an unknown voxel.
    """

    def __init__(self, index: np.ndarray, outside: int, unknown_pass: float):
        count, rays, samples = index.shape
        flat = index.reshape(count * rays, samples)
        starts = np.ones(flat.shape, dtype=bool)
        starts[:, 1:] = flat[:, 1:] != flat[:, :-1]
        run = np.cumsum(starts, axis=1)  # from 1: run 0 is the empty first one
        column = np.broadcast_to(np.arange(len(flat))[:, None], flat.shape)
        self._voxels = np.full((run.max() + 1, len(flat)), outside, dtype=np.int32)
        self._voxels[run, column] = flat
        lengths = np.zeros(self._voxels.shape, dtype=np.int64)
        np.add.at(lengths, (run, column), 1)
        # Outside the grid a run passes everything and counts nothing, however long it is.
        lengths[self._voxels == outside] = 0
        codes = np.arange(_CODES)
        sample_pass = np.select([codes >> _KIND_BITS == FREE, codes >> _KIND_BITS == UNKNOWN],
                                [1.0, unknown_pass], 0.0)
        counted = (codes[:, None] >> np.arange(_KIND_BITS)) & 1
        powers = sample_pass ** np.arange(lengths.max() + 1)[:, None]  # (length, code)
        # By key: a run's chance to pass, and what it adds to each gain per unit of visibility
        # before it (1 + p + ... + p^(m-1); nothing for the empty runs).
        self._pass = powers.ravel()
        sums = np.concatenate([np.zeros((1, _CODES)), np.cumsum(powers, axis=0)[:-1]])
        self._counts = (sums[:, :, None] * counted).reshape(-1, _KIND_BITS)
        key_type = np.min_scalar_type(len(self._pass) - 1)
        self._key_offsets = (lengths * _CODES).astype(key_type)
        self._bins = (np.arange(len(flat)) // rays * len(self._pass)).astype(np.int64)
        self._count = count

    def scores(self, codes: np.ndarray) -> np.ndarray:
        """The gains (count, len(GAINS)) of the voxel codes `codes` (flat, the extra outside
        element last)."""
        keys = np.take(codes, self._voxels).astype(self._key_offsets.dtype, copy=False)
        keys += self._key_offsets
        visible = np.take(self._pass, keys)
        for run in range(1, len(visible)):
            np.multiply(visible[run], visible[run - 1], out=visible[run])
        # Sum the visibility before each run by candidate and key, then weigh each key.
        bins = keys[1:] + self._bins
        sums = np.bincount(bins.ravel(), weights=visible[:-1].ravel(),
                           minlength=self._count * len(self._pass))
        return sums.reshape(self._count, -1) @ self._counts


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
        novel: Voxels it made occupied: its points' voxels that were not occupied before.
        occupied: Occupied voxels after it.
        informative: Whether the cell did not mostly hide it (fewer blocked pixels than
            points).
    """

    changed: np.ndarray
    previous: np.ndarray
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

    @property
    def added(self) -> list[float]:
        """Per informative frame (one the cell did not mostly hide: it says nothing about what
        is left), the share of the occupied voxels it added."""
        return [change.novel / max(change.occupied, 1) for change in self.changes
                if change is not None and change.informative]

    def update(self, views: Sequence[ViewRecord]) -> None:
        """Integrate the frames of the views not integrated yet (the episode's views so far)."""
        flat = self.grid.state.reshape(-1)
        for view in views[len(self.changes):]:
            if view.sensor_pose is None:
                self.changes.append(None)
                continue
            before = flat.copy()
            self.grid.integrate(self.settings.sensor, view.sensor_pose, view.points_world,
                                view.pixels, view.blocked_pixels)
            changed = np.flatnonzero(before != flat)
            # Only a frame's own points turn voxels occupied, and none is ever cleared.
            self.changes.append(FrameChange(
                changed, before[changed], int(np.count_nonzero(flat[changed] == OCCUPIED)),
                self.grid.counts()["occupied"],
                len(view.blocked_pixels) < len(view.points_world)))

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
        state = self.grid.state.copy()
        flat = state.reshape(-1)
        for change in reversed(self.changes[count:]):
            if change is not None:
                flat[change.changed] = change.previous
        return dataclasses.replace(self.grid, state=state)
