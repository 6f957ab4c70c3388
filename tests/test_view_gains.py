"""The sensed gains of candidate views (`vprobot.coverage.view_gains`) against hand-built grids
whose answer is known in closed form: a plate whose projector a step shadows, a plate seen past the
incidence limit, and the ideal sensor, whose gains are the camera's; the revisit gain and the
bound on what is left measurable, also against sample-by-sample references."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vprobot.config import load_config
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import (
    DIRECTIONS,
    FREE,
    GAINS,
    OCCUPIED,
    UNKNOWN,
    VOXEL_M,
    OccupancyGrid,
)
from vprobot.coverage.view_gains import (
    MEASURABLE_VISIBILITY,
    RELEVANT_VISIBILITY,
    REVISIT_DEG,
    UNKNOWN_PASS,
    ViewGains,
    measurable_share,
    ray_samples,
)
from vprobot.episode.views import band_candidates
from vprobot.geometry.poses import Pose
from vprobot.sensing.ideal import IDEAL
from vprobot.sensing.structured_light import StructuredLight

VOXEL = 0.01
SENSOR = SensorModel(resolution=(1, 1), fov_deg=(1.0, 1.0), near_m=0.3, far_m=0.6,
                     working_distance_m=0.4)
LIGHT = StructuredLight(baseline_m=0.15, max_incidence_deg=70.0,
                        projector_max_incidence_deg=70.0, noise_sigma_m=0.0,
                        noise_distance_m=0.4, dropout_grazing=0.0, dropout_exponent=1.0)
FRONTIER = GAINS.index("frontier")


def plate() -> OccupancyGrid:
    """Unknown below z = 0 (the plate, seen from nowhere yet), free above: its top layer of
    voxels is the frontier, each with the normal +z (its nine free neighbours lie above)."""
    grid = OccupancyGrid.around(np.zeros(3), 0.25, VOXEL)
    z = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * VOXEL
    grid.state[:, :, z > 0.0] = FREE
    grid.state[:, :, z < 0.0] = UNKNOWN
    return grid


def looking_at(position: np.ndarray, target: np.ndarray) -> Pose:
    """A sensor pose at `position` whose +z looks at `target` (in the world's xz plane), its
    +x (the baseline) along the world's y axis."""
    forward = (target - position) / np.linalg.norm(target - position)
    right = np.array([0.0, 1.0, 0.0])
    return Pose(position, np.column_stack([right, np.cross(forward, right), forward]))


def frontier_gains(grid: OccupancyGrid, pose: Pose) -> tuple[float, float]:
    """The camera's and the structured-light sensor's frontier gain of one ray."""
    gains = ViewGains(grid, SENSOR, [pose], rays=(1, 1), sensing=LIGHT)
    return (float(gains.camera_scores(grid)[0, FRONTIER]),
            float(gains.scores(grid)[0, FRONTIER]))


def test_a_plate_whose_projector_a_step_shadows_gains_nothing_there() -> None:
    # The camera 0.4 m above (-0.025, 0, 0), looking straight down, its projector 0.15 m
    # along +x. A wall of occupied voxels at 0.01 <= x <= 0.05, 0.2 m high, stands between the
    # projector and the point: the light from (0.125, 0, 0.4) to it runs at x = -0.025 +
    # 0.375 z, inside the wall for 0.093 <= z <= 0.2; the camera's ray (x = -0.025) passes
    # beside the wall.
    target = np.array([-0.025, 0.0, 0.0])
    pose = Pose(target + [0.0, 0.0, 0.4], np.diag([1.0, -1.0, -1.0]))
    projector = pose.position + LIGHT.baseline_m * pose.rotation[:, 0]
    np.testing.assert_allclose(projector, [0.125, 0.0, 0.4])
    grid = plate()
    camera, sensed = frontier_gains(grid, pose)
    # Without the wall the projector lights the point at 20.6 degrees: measured as seen.
    assert camera > 0.5
    assert sensed == pytest.approx(camera)
    x = grid.origin[0] + (np.arange(grid.shape[0]) + 0.5) * VOXEL
    z = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * VOXEL
    wall = ((x >= 0.01) & (x <= 0.05))[:, None, None] & ((z > 0.0) & (z <= 0.2))[None, None, :]
    grid.state[np.broadcast_to(wall, grid.shape)] = OCCUPIED
    camera_walled, sensed_walled = frontier_gains(grid, pose)
    assert camera_walled == pytest.approx(camera)  # the camera's ray passes beside it
    assert sensed_walled == 0.0


@pytest.mark.parametrize(("angle_deg", "measured"), [(30.0, True), (65.0, True), (75.0, False),
                                                    (80.0, False)])
def test_a_plate_seen_past_the_incidence_limit_gains_nothing(angle_deg: float,
                                                             measured: bool) -> None:
    # The camera 0.4 m from the origin at angle_deg from the plate's normal (+z); its
    # projector 0.15 m to its side (along the world's y), at an incidence within a few degrees
    # of the camera's: atan(0.15 / 0.4) off the camera's plane of incidence.
    angle = math.radians(angle_deg)
    pose = looking_at(0.4 * np.array([math.sin(angle), 0.0, math.cos(angle)]), np.zeros(3))
    projector = pose.position + LIGHT.baseline_m * pose.rotation[:, 0]
    projector_deg = math.degrees(math.acos(projector[2] / np.linalg.norm(projector)))
    assert abs(projector_deg - angle_deg) < 6.0 and (projector_deg < 70.0) == measured
    camera, sensed = frontier_gains(plate(), pose)
    assert camera > 0.5
    if measured:
        assert sensed == pytest.approx(camera)
    else:
        assert sensed == 0.0


def test_the_ideal_sensors_gains_are_the_cameras_on_random_grids() -> None:
    config = load_config()
    camera = band_candidates(config, VOXEL_M).gains
    grid = OccupancyGrid.for_cell(config)
    sensor = SensorModel.from_config(config.sensor)
    targets = band_candidates(config, VOXEL_M).targets
    ideal = ViewGains(grid, sensor, [target.pose for target in targets], sensing=IDEAL)
    rng = np.random.default_rng(0)
    for shares in ((1.0, 0.0, 0.0), (0.5, 0.45, 0.05), (0.2, 0.7, 0.1)):
        grid.state[:] = rng.choice([UNKNOWN, FREE, OCCUPIED], size=grid.shape, p=shares)
        expected = np.stack([camera.score(grid, gain) for gain in GAINS], axis=1)
        np.testing.assert_allclose(ideal.scores(grid), expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(ideal.scores(grid), ideal.camera_scores(grid))


def measured_plate(from_direction: np.ndarray | None) -> OccupancyGrid:
    """The plate's top layer of voxels occupied (their normal +z, from the nine free neighbours
    above), its points measured from `from_direction` (one of `DIRECTIONS`; None: never)."""
    grid = plate()
    z = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * VOXEL
    top = int(np.flatnonzero(z < 0.0)[-1])
    grid.state[:, :, top] = OCCUPIED
    if from_direction is not None:
        index = np.flatnonzero((DIRECTIONS == from_direction).all(axis=1))[0]
        grid.measured_from[:, :, top] = np.uint32(1) << np.uint32(index)
    return grid


def revisit_gains(grid: OccupancyGrid, pose: Pose, sensing: StructuredLight | None = LIGHT
                  ) -> float:
    """The revisit gain of one ray from `pose`, under structured light or the ideal sensor."""
    gains = ViewGains(grid, SENSOR, [pose], rays=(1, 1),
                      sensing=IDEAL if sensing is None else sensing)
    scores, revisits, _ = gains.revisits(grid)
    np.testing.assert_array_equal(scores, gains.scores(grid))
    return float(revisits[0])


@pytest.mark.parametrize(("angle_deg", "sensed", "ideal"), [
    (0.0, 0.0, 0.0),    # the direction the plate was measured from
    (30.0, 0.0, 0.0),   # 30 degrees off: the bin of +z still, seen
    (40.0, 0.0, 0.0),   # the bin of (1, 0, 1), next to +z's: within REVISIT_DEG, seen
    (65.0, 0.0, 0.0),   # the bin of (1, 0, 1) still
    (75.0, 0.0, 1.0),   # +x's bin, 90 degrees from +z: new; past both incidence limits
])
def test_a_plate_measured_from_above_gains_a_revisit_only_from_a_new_direction_it_can_measure(
        angle_deg: float, sensed: float, ideal: float) -> None:
    # The camera 0.4 m from the origin at angle_deg from the plate's normal; its one ray meets
    # the first occupied voxel through free space (visibility 1): a revisit weighs 1 or 0.
    angle = math.radians(angle_deg)
    pose = looking_at(0.4 * np.array([math.sin(angle), 0.0, math.cos(angle)]), np.zeros(3))
    grid = measured_plate(np.array([0.0, 0.0, 1.0]))
    assert revisit_gains(grid, pose) == sensed
    assert revisit_gains(grid, pose, sensing=None) == ideal


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 60.0])
def test_a_plate_never_measured_gains_a_revisit_of_one_ray_from_every_direction_within_the_limits(
        angle_deg: float) -> None:
    angle = math.radians(angle_deg)
    pose = looking_at(0.4 * np.array([math.sin(angle), 0.0, math.cos(angle)]), np.zeros(3))
    assert revisit_gains(measured_plate(None), pose) == pytest.approx(1.0)
    # Measured from below (the plate's back, -z): every direction above is more than 50
    # degrees from it, a new one.
    assert revisit_gains(measured_plate(np.array([0.0, 0.0, -1.0])), pose) == pytest.approx(1.0)


def test_the_revisit_gain_and_the_bound_are_a_sample_by_sample_walk_of_the_rays() -> None:
    """The ideal sensor's revisit gain and bound against a sample-by-sample reference on random
    grids: along each ray the first sample in an occupied voxel, seen with a visibility of at
    least `RELEVANT_VISIBILITY` (the product of every earlier sample's chance to pass), counts
    that visibility when none of the directions its voxel was measured from lies within
    `REVISIT_DEG` of the direction from its centre to the camera. The bound counts, once each,
    the voxels of the chosen candidates' rays seen with a visibility of at least
    `MEASURABLE_VISIBILITY` that are unknown or such a revisited occupied one, inside the box
    that bounds the occupied voxels."""
    config = load_config()
    grid = OccupancyGrid.for_cell(config)
    sensor = SensorModel.from_config(config.sensor)
    poses = [target.pose for target in band_candidates(config, VOXEL_M).targets[::8]]
    gains = ViewGains(grid, sensor, poses, rays=(8, 6), sensing=IDEAL)
    rng = np.random.default_rng(1)
    limit = math.cos(math.radians(REVISIT_DEG))
    checked = 0
    chosen = rng.random(len(poses)) < 0.6
    for shares in ((0.5, 0.45, 0.05), (0.2, 0.7, 0.1)):
        grid.state[:] = rng.choice([UNKNOWN, FREE, OCCUPIED], size=grid.shape, p=shares)
        grid.measured_from[:] = rng.integers(0, 1 << 26, size=grid.shape, dtype=np.uint32) & (
            rng.integers(0, 1 << 26, size=grid.shape, dtype=np.uint32))
        directions = sensor.at_resolution((8, 6)).ray_directions
        # Occupied voxels only in the middle half of the grid along each axis, unknown
        # elsewhere: the bound counts only inside the box about them.
        middle = np.zeros(grid.shape, dtype=bool)
        middle[tuple(slice(size // 4, size - size // 4) for size in grid.shape)] = True
        grid.state[~middle & (grid.state == OCCUPIED)] = UNKNOWN
        expected = np.zeros(len(poses))
        bound: set[int] = set()
        for candidate, pose in enumerate(poses):
            _, points = ray_samples(pose, directions, sensor, VOXEL)
            index = grid.flat_index(points)
            for ray in range(len(index)):
                visibility = 1.0
                for voxel in index[ray]:
                    state = FREE if voxel < 0 else grid.state.reshape(-1)[voxel]
                    if state == UNKNOWN and visibility >= MEASURABLE_VISIBILITY and (
                            chosen[candidate]):
                        bound.add(int(voxel))
                    if state == OCCUPIED:
                        if visibility >= RELEVANT_VISIBILITY:
                            cell = np.array(np.unravel_index(voxel, grid.shape))
                            toward = pose.position - (grid.origin + (cell + 0.5) * VOXEL)
                            toward /= np.linalg.norm(toward)
                            bits = int(grid.measured_from.reshape(-1)[voxel])
                            seen = [DIRECTIONS[bit] for bit in range(26) if bits >> bit & 1]
                            nearest = DIRECTIONS[np.argmax(DIRECTIONS @ toward)]
                            if all(nearest @ direction < limit - 1e-9 for direction in seen):
                                expected[candidate] += visibility
                                checked += 1
                                if visibility >= MEASURABLE_VISIBILITY and chosen[candidate]:
                                    bound.add(int(voxel))
                        break
                    visibility *= UNKNOWN_PASS ** 0.5 if state == UNKNOWN else 1.0
        sensed = gains.revisits(grid, chosen)
        np.testing.assert_allclose(sensed.revisit, expected, rtol=1e-5)
        cells = np.argwhere(grid.state == OCCUPIED)
        low, high = cells.min(axis=0), cells.max(axis=0)
        inside = [voxel for voxel in bound if ((np.array(np.unravel_index(voxel, grid.shape))
                                                >= low) & (np.array(np.unravel_index(
                                                    voxel, grid.shape)) <= high)).all()]
        assert 10 < len(inside) < len(bound)
        assert sensed.measurable == len(inside)
    assert checked > 50


def test_a_frame_marks_each_voxel_it_measured_with_the_direction_to_its_camera() -> None:
    """`OccupancyGrid.measured_from` after two frames of points on a plane: each voxel holding
    a point gets, per frame, the bit of the direction among its 26 neighbours' nearest to the
    direction from its centre to that frame's camera; every other voxel none."""
    grid = OccupancyGrid.around(np.zeros(3), 0.25, VOXEL)
    rng = np.random.default_rng(2)
    points = np.column_stack([rng.uniform(-0.1, 0.1, (200, 2)), np.full(200, -0.004)])
    cameras = [np.array([0.0, 0.0, 0.4]), np.array([0.3, -0.1, 0.1])]
    expected = np.zeros(grid.state.size, dtype=np.uint32)
    for camera in cameras:
        grid.integrate(SENSOR, looking_at(camera, np.zeros(3)), points,
                       np.zeros(len(points), dtype=np.int64))
        for voxel in np.unique(grid.flat_index(points)):
            cell = np.array(np.unravel_index(voxel, grid.shape))
            toward = camera - (grid.origin + (cell + 0.5) * VOXEL)
            cosines = DIRECTIONS @ (toward / np.linalg.norm(toward))
            expected[voxel] |= np.uint32(1) << np.uint32(np.argmax(cosines))
    np.testing.assert_array_equal(grid.measured_from.reshape(-1), expected)
    # The two cameras lie in different bins: every measured voxel holds two bits.
    measured = expected[expected != 0]
    assert len(measured) > 50 and (measured & (measured - 1) != 0).all()


def test_the_bound_counts_what_the_chosen_candidates_would_measure_about_the_part_once() -> None:
    # The plate's top layer unknown but for two occupied voxels, never measured, four voxels
    # apart along x: the box about them holds the three unknown voxels between them (and none
    # below). One ray straight down per candidate, through free space to the top layer.
    grid = plate()
    z = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * VOXEL
    top = int(np.flatnonzero(z < 0.0)[-1])
    middle = grid.shape[0] // 2
    grid.state[[middle, middle + 4], middle, top] = OCCUPIED

    def above(i: int) -> Pose:
        centre = grid.origin + (np.array([i, middle, top]) + 0.5) * VOXEL
        return Pose(centre + [0.0, 0.0, 0.4], np.diag([1.0, -1.0, -1.0]))

    # Twice over the same unknown voxel, over an unknown one outside the box, over an occupied
    # one never measured (a revisit).
    poses = [above(middle + 2), above(middle + 2), above(middle + 7), above(middle)]
    gains = ViewGains(grid, SENSOR, poses, rays=(1, 1), sensing=IDEAL)
    # The voxel under the first unknown one is seen with a visibility of 0.5 (counted) but lies
    # outside the box; the revisited voxel counts once.
    assert gains.revisits(grid).measurable == 2
    assert gains.revisits(grid, np.array([True, True, True, False])).measurable == 1
    assert gains.revisits(grid, np.array([False, False, True, False])).measurable == 0
    # Measured from above, the occupied voxel is no revisit from there.
    grid.measured_from[middle, middle, top] = np.uint32(1) << np.uint32(
        np.flatnonzero((DIRECTIONS == [0.0, 0.0, 1.0]).all(axis=1))[0])
    assert gains.revisits(grid).measurable == 1
    assert measurable_share(1, 2) == pytest.approx(1 / 3) and measurable_share(0, 2) == 0.0
    # Nothing seen, nothing known: all of it is still to measure.
    assert measurable_share(0, 0) == 1.0 and measurable_share(3, 0) == 1.0


def test_the_bound_drops_a_voxel_whose_projector_a_step_shadows() -> None:
    # The wall and the camera of the shadow test above; two rows of occupied voxels in the
    # plate's top layer, at x = -0.065 and 0.015 (under the wall), stretch the box about the
    # occupied voxels over the point.
    target = np.array([-0.025, 0.0, 0.0])
    pose = Pose(target + [0.0, 0.0, 0.4], np.diag([1.0, -1.0, -1.0]))
    grid = plate()
    x = grid.origin[0] + (np.arange(grid.shape[0]) + 0.5) * VOXEL
    z = grid.origin[2] + (np.arange(grid.shape[2]) + 0.5) * VOXEL
    for row in (-0.065, 0.015):
        grid.state[np.argmin(np.abs(x - row)), :, np.flatnonzero(z < 0.0)[-1]] = OCCUPIED
    for sensing in (IDEAL, LIGHT):
        assert ViewGains(grid, SENSOR, [pose], rays=(1, 1),
                         sensing=sensing).revisits(grid).measurable == 1
    wall = ((x >= 0.01) & (x <= 0.05))[:, None, None] & ((z > 0.0) & (z <= 0.2))[None, None, :]
    grid.state[np.broadcast_to(wall, grid.shape)] = OCCUPIED
    assert ViewGains(grid, SENSOR, [pose], rays=(1, 1),
                     sensing=IDEAL).revisits(grid).measurable == 1
    assert ViewGains(grid, SENSOR, [pose], rays=(1, 1),
                     sensing=LIGHT).revisits(grid).measurable == 0
