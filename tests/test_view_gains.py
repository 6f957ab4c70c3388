"""The sensed gains of candidate views (`vprobot.coverage.view_gains`) against hand-built grids
whose answer is known in closed form: a plate whose projector a step shadows, a plate seen past the
incidence limit, and the ideal sensor, whose gains are the camera's."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vprobot.config import load_config
from vprobot.config.sensor import SensorModel
from vprobot.coverage.occupancy import FREE, GAINS, OCCUPIED, UNKNOWN, VOXEL_M, OccupancyGrid
from vprobot.coverage.view_gains import ViewGains
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
