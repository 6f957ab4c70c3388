"""The gains of candidate views against an occupancy grid: what a view would see of the unknown,
and what its sensor would measure of it.

A candidate view is scored by casting a sparse grid of rays through the grid (`ViewGains`):
along each ray a sample's visibility is the product of the chances that the samples before it
let the ray through (1 for free, `UNKNOWN_PASS` per voxel for unknown, 0 for occupied), and a
gain sums the visibility of the samples of one kind (`vprobot.coverage.occupancy.GAINS`). That is
what the camera would see (`ViewGains.camera_scores`).

A structured-light sensor measures less (`vprobot.sensing.structured_light`): a point only where
its projector, `baseline_m` along the sensor's +x axis, lights it unoccluded, and where the
camera's and the projector's rays meet the surface within their incidence limits.
`ViewGains.scores` weighs every counted sample by whether the candidate's sensor would measure a
surface there, judged from the grid alone:

- the normal of a surface in an unknown voxel points to the free voxels about it (the sum of
  the offsets to its free neighbours among the 26): a surface bounds the free space it was
  looked at through. A voxel deeper in the unknown, without free neighbours, has no normal and
  counts nothing: a ray that reaches it met the unknown first where it entered, and a surface
  there is what the sensor would measure;
- the camera's ray and the ray from the projector to the voxel's centre meet that normal within
  their limits, from its free side;
- the projector lights the voxel when no occupied voxel lies in front of it: each candidate's
  occupied voxels are drawn into a depth map from its projector (`SHADOW_PIXEL_VOXELS` voxels a
  pixel at the working distance), and the voxel is in shadow where it lies farther from the
  projector than the map says, by more than a voxel and its surface's slope across a pixel.

Under structured light the gains sum the samples a candidate sees with a visibility of at least
`RELEVANT_VISIBILITY`, weighed so (the others, seen less, would add a thirtieth of a ray at most);
with the ideal sensor no weight applies and the gains are the camera's, the same numbers.

The revisit gain (`ViewGains.revisits`) counts what the unknown does not: the occupied voxels a
candidate sees (the first occupied voxel along each ray, with a visibility of at least
`RELEVANT_VISIBILITY`, weighed by it) from a direction more than `REVISIT_DEG` from every
direction their points were measured from (`OccupancyGrid.measured_from`), where its sensor would
measure them (lit, within both incidence limits, their normal from the grid as above). A
centimetre voxel seen once from one side often holds surface that view left unmeasured.

The same walk bounds what is left (`SensedGains.measurable`): the distinct voxels that some of a
given set of candidates (the reachable ones) would measure, unknown ones or occupied ones seen from
a new direction, each seen with a visibility of at least `MEASURABLE_VISIBILITY` and inside the
box that bounds the occupied voxels (about the part seen, not the cell's empty corners). Counted
against the occupied voxels, it says how much of the surface known so far is still to measure
(`measurable_share`); where it is near zero, no candidate would add much.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import (
    DIRECTIONS,
    FREE,
    GAINS,
    NEIGHBOUR_OFFSETS,
    OCCUPIED,
    UNKNOWN,
    Gain,
    OccupancyGrid,
    gain_kinds,
    nearest_direction,
)
from vprobot.geometry.poses import Pose
from vprobot.sensing.base import SensingModel
from vprobot.sensing.structured_light import StructuredLight

UNKNOWN_PASS = 0.5
"""Chance that a ray passes an unknown voxel (an uninformed prior: as likely free as not)."""
RELEVANT_VISIBILITY = 1e-2
"""Under structured light, samples seen less than this count nothing (their sensing is not
worked out; together they would add at most a thirtieth of a ray, `ViewGains.ray_bound`'s
tail)."""
SHADOW_PIXEL_VOXELS = 2.0
"""The projector's depth map: voxels per pixel at the working distance (two: a surface of
occupied voxels leaves no holes in it)."""
REVISIT_DEG = 50.0
"""A candidate revisits an occupied voxel when its direction from the voxel lies more than this
from every direction the voxel's points were measured from: binned to `DIRECTIONS`, a bin and
its neighbours 35 and 45 degrees off count as seen."""


def seen_near(angle_deg: float) -> np.ndarray:
    """Per direction bin of `DIRECTIONS`, the bits of the bins within `angle_deg` of it (itself
    included): uint32."""
    near = DIRECTIONS @ DIRECTIONS.T >= np.cos(np.deg2rad(angle_deg)) - 1e-9
    return (near @ (1 << np.arange(len(DIRECTIONS)))).astype(np.uint32)


MEASURABLE_VISIBILITY = 0.4
"""The bound (`SensedGains.measurable`) counts the voxels a candidate sees at least this well:
through free space and at most one unknown voxel (two samples pass it with 0.5; between that and
the 0.35 of a third sample, so that single precision cannot tip it)."""


class SensedGains(NamedTuple):
    """What `ViewGains.revisits` works out in one walk of the rays.

    Attributes:
        scores: Every gain of every candidate (count, len(GAINS)) as its sensor would measure it.
        revisit: Every candidate's revisit gain (count,).
        measurable: How many distinct voxels the given candidates would measure (the bound).
    """

    scores: np.ndarray
    revisit: np.ndarray
    measurable: int


def measurable_share(measurable: int, occupied: int) -> float:
    """The share of the surface known so far (the occupied voxels and the measurable ones) that
    is still to measure: 0 when nothing is measurable, 1 before anything was seen."""
    known = measurable + occupied
    return measurable / known if known else 1.0


_SEEN_NEAR = seen_near(REVISIT_DEG)
_KIND_BITS = len(GAINS)
_CODES = (OCCUPIED + 1) << _KIND_BITS
_KIND_MASK = (1 << _KIND_BITS) - 1
_CHUNK_RUNS = 6
"""Runs walked at a time by `_SampleRuns.relevant` before it drops the rays it is done with."""


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
        sensing: How the sensor measures (`vprobot.sensing`); structured light weighs the gains
            by what its projector lights and its incidence limits, any other model measures
            what the camera sees.
    """

    def __init__(self, grid: OccupancyGrid, sensor: SensorModel, poses: list[Pose],
                 rays: tuple[int, int] = (16, 12), sensing: SensingModel | None = None):
        directions = sensor.at_resolution(rays).ray_directions
        index = grid.flat_index(np.stack([ray_samples(pose, directions, sensor, grid.voxel_m)[1]
                                          for pose in poses]))
        # Samples outside the grid read an extra last element that counts as free space.
        self._index = np.where(index >= 0, index, grid.state.size).astype(np.int32)
        # Two samples per voxel: each passes an unknown voxel with the root of its chance.
        self._unknown_pass = UNKNOWN_PASS ** 0.5
        self._runs = _SampleRuns(self._index, grid.state.size, self._unknown_pass)
        self._cameras = np.stack([pose.position for pose in poses]).astype(np.float32)
        self._light = (_Projectors(grid, sensor, poses, sensing)
                       if isinstance(sensing, StructuredLight) else None)

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
        """The camera's gain of every candidate (count,) against the grid's current state,
        sample by sample (the reference of `camera_scores`)."""
        state = np.append(grid.state.reshape(-1), np.int8(FREE))[self._index]
        passes = np.where(state == FREE, 1.0,
                          np.where(state == UNKNOWN, self._unknown_pass, 0.0))
        counted = np.append(grid.kind_mask(gain).reshape(-1), False)[self._index]
        return (self._seen(passes) * counted).sum(axis=(1, 2))

    def camera_scores(self, grid: OccupancyGrid) -> np.ndarray:
        """Every gain of every candidate (count, len(GAINS)) as the camera sees it: `score`
        of each gain, computed over the runs of samples in one voxel."""
        codes = _codes(grid)
        keys, visible = self._runs.visibility(codes)
        return self._runs.sums(keys, visible[:-1])

    def scores(self, grid: OccupancyGrid) -> np.ndarray:
        """Every gain of every candidate (count, len(GAINS)) as the sensor would measure it."""
        if self._light is None:
            return self.camera_scores(grid)
        keys, voxels, columns, weights = self._runs.relevant(_codes(grid), RELEVANT_VISIBILITY)
        candidates = columns // self.rays
        weights *= self._light.measured(grid, voxels, candidates)
        return self._runs.sums_at(keys, candidates, weights)

    def revisits(self, grid: OccupancyGrid, candidates: np.ndarray | None = None
                 ) -> SensedGains:
        """`scores`, every candidate's revisit gain (count,): the visibility of the occupied
        voxels its rays stop at that it sees from a direction none of their points was measured
        from (`REVISIT_DEG`) and its sensor would measure, and the bound over `candidates` (a
        mask; None: all). One walk of the rays for all three."""
        keys, voxels, columns, weights = self._runs.relevant(_codes(grid), RELEVANT_VISIBILITY,
                                                             stops=True)
        views = columns // self.rays
        # The runs of occupied voxels carry no gain bit: the gains' sums read nothing of them.
        counted = self._runs.kinds(keys) != 0
        stop = ~counted
        stops = np.flatnonzero(stop)
        toward = (np.take(self._cameras, views[stops], axis=0)
                  - grid.centres_of(np.array(np.unravel_index(voxels[stops], grid.shape))).T)
        near = _SEEN_NEAR[nearest_direction(toward)]
        # Stops seen from a direction already measured are dropped before their sensing is
        # worked out: most of them, once a few views were taken.
        stop[stops[(np.take(grid.measured_from.reshape(-1), voxels[stops]) & near) != 0]] = False
        kept = np.flatnonzero(counted | stop)
        keys, voxels, views, weights, stop = (keys[kept], voxels[kept], views[kept],
                                              weights[kept], stop[kept])
        if self._light is not None:
            weights *= self._light.measured(grid, voxels, views)
        measurable = weights >= MEASURABLE_VISIBILITY
        if candidates is not None:
            measurable &= candidates[views]
        revisit = np.bincount(views[stop], weights=weights[stop], minlength=len(self))
        weights[stop] = 0.0
        return SensedGains(self._runs.sums_at(keys, views, weights), revisit,
                           _count_in_box(grid, voxels[measurable]))


def _count_in_box(grid: OccupancyGrid, voxels: np.ndarray) -> int:
    """How many distinct voxels of `voxels` (flat, repeats allowed) lie in the box that bounds
    the grid's occupied voxels (`OccupancyGrid.occupied_box`)."""
    box = grid.occupied_box()
    if box is None:
        return 0
    marked = np.zeros(grid.state.size + 1, dtype=bool)
    marked[voxels] = True
    return int(np.count_nonzero(marked[:-1].reshape(grid.shape)[box]))


_STATE_BITS = OCCUPIED + 1
"""Bits of `OccupancyGrid.neighbours`: one per state."""


def _code_table() -> np.ndarray:
    """The code of a voxel (state << 3 | one bit per gain) by its state and its neighbours'
    states (`OccupancyGrid.neighbours`): at `state << _STATE_BITS | neighbours`."""
    state, neighbours = np.divmod(np.arange((OCCUPIED + 1) << _STATE_BITS), 1 << _STATE_BITS)
    code = state << _KIND_BITS
    for bit, mask in enumerate(gain_kinds(state, neighbours)):
        code |= mask.astype(int) << bit
    return code.astype(np.uint8)


_CODE_TABLE = _code_table()


def _codes(grid: OccupancyGrid) -> np.ndarray:
    """Every voxel's code (state << 3 | one bit per gain), the outside element (free) last."""
    codes = np.empty(grid.state.size + 1, dtype=np.uint8)
    key = grid.neighbours()
    key |= grid.state.view(np.uint8) << _STATE_BITS
    np.take(_CODE_TABLE, key.reshape(-1), out=codes[:-1])
    codes[-1] = FREE << _KIND_BITS
    return codes


class _Projectors:
    """The candidates' projectors: where each lights and at what incidence, from a grid.

    Args:
        grid: The grid (its geometry).
        sensor: The camera's opening angles and working distance.
        poses: The candidates' sensor poses (the camera's).
        light: The structured-light figures (baseline, incidence limits).
    """

    def __init__(self, grid: OccupancyGrid, sensor: SensorModel, poses: list[Pose],
                 light: StructuredLight):
        self._rotations = np.stack([pose.rotation for pose in poses]).astype(np.float32)
        cameras = np.stack([pose.position for pose in poses]).astype(np.float32)
        projectors = cameras + light.baseline_m * self._rotations[:, :, 0]
        # Positions by axis (3, count), so that gathering them by candidate reads rows. R[j, i]
        # of every candidate at row 3 j + i (9, count), and each projector's position in its
        # own frame: what moving points into the projectors' frames reads.
        self._cameras = np.ascontiguousarray(cameras.T)
        self._projectors = np.ascontiguousarray(projectors.T)
        self._axes = self._rotations.reshape(len(self._rotations), 9).T
        self._projectors_local = np.einsum("cji,cj->ci", self._rotations, projectors)
        self._min_cos = light.min_cos_incidence
        self._voxel = grid.voxel_m
        # The depth map spans every direction in which the projector can light a point the
        # camera sees within range: the camera's field, shifted by the baseline at the near
        # bound along x, and a pixel more on every side for the voxels' centres, which lie up to
        # a voxel off the camera's rays.
        half_x, half_y = sensor.half_tangents
        self._pitch = SHADOW_PIXEL_VOXELS * grid.voxel_m / sensor.working_distance_m
        self._low = np.array([-half_x - light.baseline_m / sensor.near_m, -half_y]) - self._pitch
        self._size = np.ceil((np.array([half_x, half_y]) + self._pitch - self._low)
                             / self._pitch).astype(int)
        shape = np.array(grid.shape)
        self._padded_shape = tuple(shape + 2)
        self._padded_offsets = np.ravel_multi_index(
            (NEIGHBOUR_OFFSETS + 1).T, self._padded_shape) - int(
            np.ravel_multi_index((1, 1, 1), self._padded_shape))

    def _pixels(self, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The depth-map pixel (flat) of points in a projector's frame (3, ...), and whether
        they lie in front of it and in the map."""
        z = local[2]
        with np.errstate(divide="ignore", invalid="ignore"):
            column = np.floor((local[0] / z - self._low[0]) / self._pitch)
            row = np.floor((local[1] / z - self._low[1]) / self._pitch)
        inside = (z > 0.0) & (column >= 0) & (column < self._size[0]) & (row >= 0) & (
            row < self._size[1])
        pixel = np.where(inside, row * self._size[0] + column, 0).astype(np.int64)
        return pixel, inside

    def _depth_maps(self, grid: OccupancyGrid) -> np.ndarray:
        """Per candidate, the distance from its projector to the nearest occupied voxel centre
        in each pixel of its depth map (candidates, pixels); inf where none."""
        occupied = np.flatnonzero(grid.state.reshape(-1) == OCCUPIED)
        count, pixels = len(self._rotations), int(np.prod(self._size))
        maps = np.full(count * pixels, np.inf, dtype=np.float32)
        if len(occupied):
            centres = np.take(grid.centres, occupied, axis=1)  # (3, k)
            local = (np.einsum("cji,jk->cik", self._rotations, centres)
                     - self._projectors_local[:, :, None])
            pixel, inside = self._pixels(np.moveaxis(local, 1, 0))
            distance = np.sqrt(np.einsum("cik,cik->ck", local, local))
            keys = pixel + (np.arange(count) * pixels)[:, None]
            np.minimum.at(maps, keys[inside], distance[inside])
        return maps.reshape(count, pixels)

    def _normals(self, grid: OccupancyGrid, cells: np.ndarray) -> np.ndarray:
        """The surface normal (3, n) at the voxels of cells (3, n) from their free neighbours;
        zero without."""
        free = np.pad(grid.state == FREE, 1).reshape(-1).view(np.int8)
        padded = np.ravel_multi_index(cells + 1, self._padded_shape)
        sums = np.zeros(cells.shape, dtype=np.int16)
        for offset, flat in zip(NEIGHBOUR_OFFSETS, self._padded_offsets, strict=True):
            near = np.take(free, padded + flat)
            for axis in np.flatnonzero(offset):
                if offset[axis] > 0:
                    sums[axis] += near
                else:
                    sums[axis] -= near
        return sums.astype(np.float32)

    def measured(self, grid: OccupancyGrid, voxels: np.ndarray,
                 candidates: np.ndarray) -> np.ndarray:
        """Whether the candidate's sensor would measure a surface in each voxel (1 or 0,
        float32): lit by its projector and within both incidence limits."""
        measured = np.zeros(len(voxels), dtype=np.float32)
        # The distinct voxels, in order, and each entry's slot among them (marks per voxel:
        # cheaper than sorting them).
        marked = np.zeros(grid.state.size + 1, dtype=bool)
        marked[voxels] = True
        unique = np.flatnonzero(marked)
        slots = np.empty(len(marked), dtype=np.int32)
        slots[unique] = np.arange(len(unique), dtype=np.int32)
        slot = slots[voxels]
        cells = np.array(np.unravel_index(unique, grid.shape))
        normals = self._normals(grid, cells)
        length = np.sqrt((normals * normals).sum(axis=0))
        has_normal = length > 0.0
        np.divide(normals, length, out=normals, where=has_normal)
        # Each test below is worked out only for the entries that passed the ones before: a
        # voxel without a normal holds no surface, a surface turned away is not measured.
        entries = np.flatnonzero(has_normal[slot])
        slot, candidates = slot[entries], candidates[entries]
        normal = np.take(normals, slot, axis=1)
        centres = np.take(grid.centres_of(cells), slot, axis=1)
        view = centres - np.take(self._cameras, candidates, axis=1)
        light = centres - np.take(self._projectors, candidates, axis=1)
        cos_camera = -(view * normal).sum(axis=0) / np.sqrt((view * view).sum(axis=0))
        light_distance = np.sqrt((light * light).sum(axis=0))
        cos_projector = -(light * normal).sum(axis=0) / light_distance
        min_camera, min_projector = self._min_cos
        facing = np.flatnonzero((cos_camera > 0.0) & (cos_camera >= min_camera)
                                & (cos_projector > 0.0) & (cos_projector >= min_projector))
        entries, candidates = entries[facing], candidates[facing]
        light, light_distance = light[:, facing], light_distance[facing]
        cos_projector = cos_projector[facing]
        axes = np.take(self._axes, candidates, axis=1)
        local = axes[0:3] * light[0]
        local += axes[3:6] * light[1]
        local += axes[6:9] * light[2]
        pixel, inside = self._pixels(local)
        maps = self._depth_maps(grid)
        # Shadow where an occupied voxel lies in front by more than a voxel and the slope of
        # the surface across a pixel (a surface does not shadow itself).
        across = self._pitch * local[2]
        slope = (np.sqrt(np.maximum(1.0 - cos_projector ** 2, 0.0))
                 / np.maximum(cos_projector, 0.2))
        lit = ~inside | (light_distance <= maps[candidates, pixel] + self._voxel + across * slope)
        measured[entries[lit]] = 1.0
        return measured


class _SampleRuns:
    """The samples of every ray as runs of consecutive samples in one voxel, for the scores.

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

    Attributes:
        voxels: The voxel of every run (runs, candidates x rays); `outside` for the empty
            first runs and past a ray's end.
    """

    def __init__(self, index: np.ndarray, outside: int, unknown_pass: float):
        count, rays, samples = index.shape
        flat = index.reshape(count * rays, samples)
        starts = np.ones(flat.shape, dtype=bool)
        starts[:, 1:] = flat[:, 1:] != flat[:, :-1]
        run = np.cumsum(starts, axis=1)  # from 1: run 0 is the empty first one
        column = np.broadcast_to(np.arange(len(flat))[:, None], flat.shape)
        self.voxels = np.full((run.max() + 1, len(flat)), outside, dtype=np.int32)
        self.voxels[run, column] = flat
        inside = self.voxels != outside
        # The last run of every ray inside the grid (0 for a ray that misses it).
        self._last = np.where(inside.any(axis=0),
                              len(inside) - 1 - np.argmax(inside[::-1], axis=0), 0)
        lengths = np.zeros(self.voxels.shape, dtype=np.int64)
        np.add.at(lengths, (run, column), 1)
        # Outside the grid a run passes everything and counts nothing, however long it is.
        lengths[self.voxels == outside] = 0
        codes = np.arange(_CODES)
        sample_pass = np.select([codes >> _KIND_BITS == FREE, codes >> _KIND_BITS == UNKNOWN],
                                [1.0, unknown_pass], 0.0)
        counted = (codes[:, None] >> np.arange(_KIND_BITS)) & 1
        powers = sample_pass ** np.arange(lengths.max() + 1)[:, None]  # (length, code)
        # By key: a run's chance to pass, and what it adds to each gain per unit of visibility
        # before it (1 + p + ... + p^(m-1); nothing for the empty runs).
        self._pass = powers.ravel()
        # The sensed gains' walk (`relevant`) multiplies in single precision, reading half the
        # bytes: each of its visibilities is a product of at most a few hundred factors, and
        # only whether it reaches a threshold and what it weighs are read.
        self._pass_single = self._pass.astype(np.float32)
        sums = np.concatenate([np.zeros((1, _CODES)), np.cumsum(powers, axis=0)[:-1]])
        self._counts = (sums[:, :, None] * counted).reshape(-1, _KIND_BITS)
        key_type = np.min_scalar_type(len(self._pass) - 1)
        self._key_offsets = (lengths * _CODES).astype(key_type)
        self._bins = (np.arange(len(flat)) // rays * len(self._pass)).astype(np.int64)
        self._count = count

    def visibility(self, codes: np.ndarray, single: bool = False
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Every run's key and the visibility after it (runs, columns), for voxel codes `codes`
        (flat, the extra outside element last); in single precision, as `relevant` works it
        out, if `single`."""
        keys = np.take(codes, self.voxels).astype(self._key_offsets.dtype, copy=False)
        keys += self._key_offsets
        visible = np.take(self._pass_single if single else self._pass, keys)
        for run in range(1, len(visible)):
            np.multiply(visible[run], visible[run - 1], out=visible[run])
        return keys, visible

    @staticmethod
    def kinds(keys: np.ndarray) -> np.ndarray:
        """The gain bits of the voxel of every run of `keys` (uint8, same shape): a key's low
        bits, as `_CODES` is a multiple of their range."""
        return keys & _KIND_MASK

    def relevant(self, codes: np.ndarray, threshold: float, stops: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The runs a gain counts (of a voxel with a gain bit) seen with a visibility of at
        least `threshold`: their keys, voxels, columns and the visibility before them, run by
        run (as `visibility`'s rows in single precision, the same products); with `stops`
        also the runs of occupied voxels so seen, where their rays stop.

        Visibility only falls along a ray, and a ray never comes back into the grid, so the
        runs are walked `_CHUNK_RUNS` at a time over the rays still seen that well and still
        to cross the grid: most rays are done within a few dozen runs."""
        live = np.arange(self.voxels.shape[1])
        before = np.ones(len(live), dtype=self._pass_single.dtype)
        found = []
        for start in range(1, len(self.voxels), _CHUNK_RUNS):
            stop = min(start + _CHUNK_RUNS, len(self.voxels))
            voxels = np.take(self.voxels[start:stop], live, axis=1)
            keys = np.take(codes, voxels).astype(self._key_offsets.dtype, copy=False)
            keys += np.take(self._key_offsets[start:stop], live, axis=1)
            passes = np.take(self._pass_single, keys)
            seen = np.empty_like(passes)
            seen[0] = before
            for run in range(1, len(seen)):
                np.multiply(passes[run - 1], seen[run - 1], out=seen[run])
            counted = self.kinds(keys) != 0
            if stops:
                counted |= passes == 0.0  # only an occupied run lets nothing through
            flat = np.flatnonzero(counted & (seen >= threshold))
            found.append((keys.reshape(-1)[flat], voxels.reshape(-1)[flat],
                          live[flat % len(live)], seen.reshape(-1)[flat]))
            after = passes[-1] * seen[-1]
            keep = (after >= threshold) & (self._last[live] >= stop)
            live, before = live[keep], after[keep]
            if not len(live):
                break
        keys, voxels, columns, seen = (np.concatenate(part) for part in zip(*found, strict=True))
        return keys, voxels, columns, seen

    def sums_at(self, keys: np.ndarray, candidates: np.ndarray,
                weights: np.ndarray) -> np.ndarray:
        """The gains (count, len(GAINS)) of some runs: their keys, candidates and weights."""
        sums = np.bincount(candidates * len(self._pass) + keys, weights=weights,
                           minlength=self._count * len(self._pass))
        return sums.reshape(self._count, -1) @ self._counts

    def sums(self, keys: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """The gains (count, len(GAINS)): each run's key weighed by `weights`, the visibility
        before it (runs - 1, columns)."""
        bins = keys[1:] + self._bins
        sums = np.bincount(bins.ravel(), weights=weights.ravel(),
                           minlength=self._count * len(self._pass))
        return sums.reshape(self._count, -1) @ self._counts
