"""Tests of the ray-cast sensor against analytic references and brute-force MuJoCo ray casts."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh
from helpers import make_scene

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import DepthSensor, _segments_meet_box
from vprobot.config import Config, SensorConfig
from vprobot.config.sensor import SensorModel
from vprobot.files.paths import MOTORS_DIR
from vprobot.geometry.poses import Pose
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.parts.loading import load_mesh

WIDE = SensorModel.from_config(SensorConfig(fov_deg=(40.0, 40.0), near_m=0.2, far_m=0.6))


def _surface_area(sensor: DepthSensor, pose: Pose, points: np.ndarray, pixels: np.ndarray,
                  normals: np.ndarray) -> float:
    """Area of the surface behind the hit pixels: solid angle * distance^2 / cos(incidence)."""
    pixel_tangents = 2 * np.tan(np.deg2rad(sensor.sensor.fov_deg) / 2) / sensor.resolution
    directions = sensor.directions[pixels]
    solid_angle = np.prod(pixel_tangents) * directions[:, 2] ** 3
    distance = np.linalg.norm(points - pose.position, axis=1)
    cosine = np.abs(np.einsum("ij,ij->i", directions @ pose.rotation.T, normals))
    return float(np.sum(solid_angle * distance**2 / cosine))


def test_ray_directions_are_an_even_row_major_grid() -> None:
    sensor = SensorModel.from_config(SensorConfig(resolution=(43, 30)))
    directions = sensor.ray_directions
    assert directions.shape == (30 * 43, 3)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
    tangents = directions[:, :2] / directions[:, 2:]
    grid = tangents.reshape(30, 43, 2)
    # +x is image right (columns), +y image down (rows); pixel centres of an even grid.
    half_x, half_y = np.tan(np.deg2rad(13.5)), np.tan(np.deg2rad(12.5))
    np.testing.assert_allclose(grid[0, :, 0], half_x * ((2 * np.arange(43) + 1) / 43 - 1))
    np.testing.assert_allclose(grid[:, 0, 1], half_y * ((2 * np.arange(30) + 1) / 30 - 1))
    assert np.all(np.diff(grid[:, :, 1], axis=0) > 0) and np.all(np.diff(grid[:, :, 0]) > 0)
    assert sensor.at_resolution((4, 3)).ray_directions.shape == (12, 3)


@pytest.mark.parametrize("resolution", [(0, 10), (10,), (2.5, 3)])
def test_bad_resolution_is_rejected(resolution: tuple) -> None:
    with pytest.raises(ValueError, match="resolution"):
        SensorModel.from_config(SensorConfig()).at_resolution(resolution)


def test_bad_worker_count_is_rejected() -> None:
    scene, _ = make_scene(trimesh.creation.box((0.1, 0.1, 0.1)))
    with pytest.raises(ValueError, match="workers"):
        DepthSensor(scene, WIDE, workers=0)


def test_object_sharing_a_group_with_primitives_is_rejected() -> None:
    scene, _ = make_scene(trimesh.creation.box((0.1, 0.1, 0.1)),
                          boxes=[((0.0, 0.0, 1.0), (0.1, 0.1, 0.01))])
    scene.model.geom_group[scene.model.geom("box0").id] = 1
    with pytest.raises(ValueError, match="group"):
        DepthSensor(scene, WIDE)


@pytest.mark.parametrize(("radius", "distance"), [(0.1, 0.45), (0.08, 0.35)])
def test_sphere_shows_the_spherical_cap(radius: float, distance: float) -> None:
    scene, data = make_scene(trimesh.creation.icosphere(subdivisions=6, radius=radius))
    sensor = DepthSensor(scene, WIDE, resolution=(300, 300))
    # Slightly off the grid's symmetry so that no alignment of pixels and limb is favoured.
    pose = Pose.look_at([0.0021, -0.0013, distance], [0.0, 0.0, 0.0])
    distance = float(np.linalg.norm(pose.position))
    acquisition = sensor.acquire_from_pose(data, pose)
    points = acquisition.points_object
    normals = points / np.linalg.norm(points, axis=1, keepdims=True)
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), radius, atol=radius * 2e-4)
    # Every hit faces the sensor, and the visible cap reaches out to cos(polar) = R / D.
    assert np.all(np.einsum("ij,ij->i", normals, pose.position - points) > 0)
    polar = np.arccos(np.clip(normals @ (pose.position / distance), -1.0, 1.0)).max()
    visible_fraction = (1.0 - np.cos(polar)) / 2.0
    assert visible_fraction == pytest.approx((1.0 - radius / distance) / 2.0, abs=0.01)
    # Every ray that meets the sphere (a pixel inside its silhouette) returns a point.
    rays = sensor.directions @ pose.rotation.T
    along = -rays @ pose.position
    miss_distance = np.sqrt(np.maximum(pose.position @ pose.position - along**2, 0.0))
    inside = np.flatnonzero(miss_distance < radius * 0.998)
    assert np.isin(inside, acquisition.pixels).all()


def test_cube_face_on_shows_one_face() -> None:
    side = 0.1
    scene, data = make_scene(trimesh.creation.box((side, side, side)))
    sensor = DepthSensor(scene, resolution=(215, 150))
    pose = Pose.look_at([0.003, -0.002, 0.45], [0.003, -0.002, 0.0])
    acquisition = sensor.acquire_from_pose(data, pose)
    points = acquisition.points_object
    np.testing.assert_allclose(points[:, 2], side / 2, atol=1e-9)
    # Looking straight down, image x is world x and image y is world -y.
    np.testing.assert_allclose(pose.rotation, np.diag([1.0, -1.0, -1.0]), atol=1e-12)
    # Exact reference from the documented pixel grid: the ray through pixel centre (u_j, v_i)
    # meets the top face, D = 0.4 m below the sensor, at x = 0.003 + D u_j, y = -0.002 - D v_i,
    # and the face holds it iff |x|, |y| <= side / 2 (no ray outside it reaches a side face).
    (width, height), depth = sensor.resolution, 0.45 - side / 2
    tan_x, tan_y = np.tan(np.deg2rad(sensor.sensor.fov_deg) / 2)
    u = tan_x * ((2 * np.arange(width) + 1) / width - 1)
    v = tan_y * ((2 * np.arange(height) + 1) / height - 1)
    margin_x = side / 2 - np.abs(0.003 + depth * u)
    margin_y = side / 2 - np.abs(-0.002 - depth * v)
    # No hit lies within 0.05 mm of an edge, so rounding (float32 vertices) cannot move the count.
    assert min(np.abs(margin_x).min(), np.abs(margin_y).min()) > 5e-5
    columns, rows = np.flatnonzero(margin_x >= 0), np.flatnonzero(margin_y >= 0)
    assert (len(columns), len(rows)) == (112, 85)
    np.testing.assert_array_equal(acquisition.pixels, (rows[:, None] * width + columns).ravel())
    expected_xy = np.stack(np.broadcast_arrays(0.003 + depth * u[columns][None, :],
                                               -0.002 - depth * v[rows][:, None]), axis=-1)
    np.testing.assert_allclose(points[:, :2], expected_xy.reshape(-1, 2), atol=1e-9)
    # On a face normal to the axis every pixel covers exactly (pitch_u D) x (pitch_v D), so the
    # area sums to 112 * 85 pixels: 1.0055 side^2, the pixel centres sampling each edge to
    # within half a pixel (0.89 x 1.18 mm here).
    normals = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    area = _surface_area(sensor, pose, points, acquisition.pixels, normals)
    pixel_area = (u[1] - u[0]) * (v[1] - v[0]) * depth**2
    assert area == pytest.approx(112 * 85 * pixel_area, rel=1e-6)


@pytest.mark.parametrize(("distance", "target"), [
    (0.58, (0.0, 0.0, 0.0)),    # nearest surface 0.53 m: beyond far
    (0.30, (0.0, 0.0, 0.0)),    # farthest visible surface < 0.30 m: nearer than near
    (0.45, (0.0, 0.0, 0.9)),    # looking away from the object
    (0.45, (3.0, 0.0, 0.45)),   # looking past it
])
def test_nothing_out_of_range_or_out_of_view(distance: float, target: tuple) -> None:
    scene, data = make_scene(trimesh.creation.icosphere(subdivisions=3, radius=0.05))
    sensor = DepthSensor(scene)
    acquisition = sensor.acquire_from_pose(data, Pose.look_at([0.0, 0.0, distance], target))
    assert len(acquisition) == 0
    assert acquisition.points_world.shape == (0, 3)
    assert acquisition.rays_cast == 430 * 300


def test_only_hits_within_near_and_far_are_kept() -> None:
    # A long bar along the viewing axis crosses both range limits.
    scene, data = make_scene(trimesh.creation.box((0.05, 0.05, 0.4)))
    sensor = DepthSensor(scene, resolution=(86, 60))
    pose = Pose.look_at([0.2, 0.0, 0.4], [0.0, 0.0, 0.0])
    acquisition = sensor.acquire_from_pose(data, pose)
    distance = np.linalg.norm(acquisition.points_world - pose.position, axis=1)
    assert len(acquisition) > 0
    assert distance.min() >= 0.30 and distance.max() <= 0.50
    assert distance.min() < 0.31 and distance.max() > 0.49


@pytest.mark.parametrize("kind", ["primitive", "mesh"])
def test_plate_over_half_the_frustum_removes_the_shadowed_points(kind: str) -> None:
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    pose = Pose.look_at([0.002, 0.001, 0.45], [0.002, 0.001, 0.0])
    # A plate at 0.2 m in front of the sensor covers the image's lower half (+y image down).
    plate = ((0.0, -0.2, 0.25), (0.2, 0.2, 0.002))
    plain_scene, plain_data = make_scene(box)
    plates = {"boxes": [plate]} if kind == "primitive" else {"mesh_boxes": [plate]}
    scene, data = make_scene(box, **plates)
    resolution = (172, 120)
    plain = DepthSensor(plain_scene, resolution=resolution).acquire_from_pose(plain_data, pose)
    shadowed = DepthSensor(scene, resolution=resolution).acquire_from_pose(data, pose)
    # Reference: a ray is shadowed iff it crosses the plate's top or bottom face inside the
    # plate (a ray through a side face also leaves through the bottom).
    rays = plain.points_world - pose.position
    shadowed_rays = np.zeros(len(rays), dtype=bool)
    for height in (0.252, 0.248):
        crossing = pose.position + rays * ((height - pose.position[2]) / rays[:, 2])[:, None]
        shadowed_rays |= (np.abs(crossing[:, 0]) <= 0.2) & (np.abs(crossing[:, 1] + 0.2) <= 0.2)
    assert 0.3 < shadowed_rays.mean() < 0.7
    np.testing.assert_array_equal(shadowed.pixels, plain.pixels[~shadowed_rays])
    np.testing.assert_allclose(shadowed.points_world, plain.points_world[~shadowed_rays])


def test_primitive_occluder_away_from_the_world_origin_hides_the_object() -> None:
    """MuJoCo's ray casts bound each body by its inertial frame: the sensor's own MjData copies
    must carry it (`ximat`), or a primitive off the rays' way to the world origin is missed."""
    floor = trimesh.creation.box((0.8, 0.6, 0.01))
    floor.apply_translation([0.0, 0.0, 0.095])
    pose = Pose.look_at([0.1013, -0.0007, 0.5], [0.1013, -0.0007, 0.0])
    center, half = np.array([0.1213, -0.0007, 0.3]), np.array([0.02, 0.03, 0.002])
    plain_scene, plain_data = make_scene(floor)
    scene, data = make_scene(floor, boxes=[(center, half)])
    resolution = (172, 120)
    plain = DepthSensor(plain_scene, resolution=resolution).acquire_from_pose(plain_data, pose)
    shadowed = DepthSensor(scene, resolution=resolution).acquire_from_pose(data, pose)
    rays = plain.points_world - pose.position
    hidden = np.zeros(len(rays), dtype=bool)
    for height in (center[2] - half[2], center[2] + half[2]):
        crossing = pose.position + rays * ((height - pose.position[2]) / rays[:, 2])[:, None]
        hidden |= np.all(np.abs(crossing[:, :2] - center[:2]) <= half[:2], axis=1)
    assert 0.1 < hidden.mean() < 0.5
    np.testing.assert_array_equal(shadowed.pixels, plain.pixels[~hidden])


@pytest.fixture(scope="module")
def motor_cell() -> Cell:
    return Cell(Config(), load_mesh(MOTORS_DIR / "test" / "motor_000.stl").mesh)


# Joint configurations (collision-free) that put a link between the sensor and the motor.
FOREARM_IN_VIEW = (-2.85, -2.04, -1.94, 0.23, -0.31, 2.87)
UPPER_ARM_IN_VIEW = (-1.56, -1.8, 2.72, 0.75, -0.35, -2.75)


@pytest.mark.parametrize(("direction_index", "joints"), [
    (0, None), (15, None), (31, None), (39, None), (5, FOREARM_IN_VIEW), (19, UPPER_ARM_IN_VIEW),
])
def test_matches_brute_force_mujoco_rays_in_the_cell(motor_cell: Cell, direction_index: int,
                                                     joints: tuple | None) -> None:
    """Same points as one `mj_multiRay` over every ray of the frame, robot and fixture included.

    The views cover clear lines of sight (robot at home), views from below where the fixture
    plate and pedestal hide parts of the motor, and views where the forearm or the upper arm
    hides part of it.
    """
    cell = motor_cell
    data = cell.make_data()
    if joints is not None:
        data.qpos[:] = joints
        mujoco.mj_kinematics(cell.model, data)
    sensor = DepthSensor(cell, resolution=(215, 150))
    direction = sphere_directions(40)[direction_index]
    pose = Pose.look_at(cell.object_center + 0.45 * direction,
                        cell.object_center + [0.01, -0.02, 0.005])
    acquisition = sensor.acquire_from_pose(data, pose)

    rays = sensor.directions @ pose.rotation.T
    count = len(rays)

    def brute_force(geomgroup: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        geom_id, distance = np.empty(count, np.int32), np.empty(count)
        mujoco.mj_multiRay(cell.model, data, pose.position, rays.ravel(), geomgroup, 1,
                           cell.sensor_body_id, geom_id, distance, None, count, 10.0)
        kept = (np.isin(geom_id, cell.object_geom_ids) & (distance >= 0.3) & (distance <= 0.5))
        return np.flatnonzero(kept), geom_id, distance

    expected, geom_id, distance = brute_force(None)
    # Never an empty frame against an empty frame.
    assert len(expected) > 2000
    if joints is not None:
        # The robot really hides part of the motor, and only part: without the robot's geom
        # group (2) MuJoCo sees about twice as many object points, and every one of them that
        # the full cast lost is hidden by a robot link.
        unoccluded = brute_force(np.array([1, 1, 0, 1, 1, 1], np.uint8))[0]
        assert len(unoccluded) > 1.8 * len(expected)
        assert np.isin(expected, unoccluded).all()
        hidden = np.setdiff1d(unoccluded, expected)
        assert np.isin(geom_id[hidden], cell.robot_geom_ids).all()
    np.testing.assert_array_equal(acquisition.pixels, expected)
    np.testing.assert_allclose(acquisition.points_world,
                               pose.position + rays[expected] * distance[expected, None],
                               atol=1e-9)


def test_frames_of_the_points(motor_cell: Cell) -> None:
    cell = motor_cell
    data = cell.make_data()
    angle = np.deg2rad(30.0)
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0.0],
                         [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])
    cell.place_object(data, rotation)
    pose = Pose.look_at(cell.object_center + [0.1, 0.3, 0.33], cell.object_center)
    acquisition = DepthSensor(cell, resolution=(107, 75)).acquire_from_pose(data, pose)
    assert len(acquisition) > 500
    np.testing.assert_allclose(acquisition.points_object,
                               acquisition.points_world - cell.object_center)
    assert acquisition.sensor_pose is pose
    np.testing.assert_allclose(acquisition.object_pose.rotation, rotation, atol=1e-9)
    mesh = load_mesh(MOTORS_DIR / "test" / "motor_000.stl").mesh
    _, gap, _ = trimesh.proximity.closest_point(mesh, acquisition.points_mesh)
    # MuJoCo keeps float32 vertices; at grazing incidence their rounding moves a hit along its ray.
    assert np.quantile(gap, 0.99) < 1e-7 and gap.max() < 1e-4


def test_acquire_uses_the_sensor_site(motor_cell: Cell) -> None:
    cell = motor_cell
    data = cell.make_data()
    sensor = DepthSensor(cell, resolution=(107, 75))
    site = cell.sensor_site_id
    pose = Pose(data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy())
    from_site = sensor.acquire(data)
    np.testing.assert_array_equal(from_site.sensor_pose.position, pose.position)
    np.testing.assert_array_equal(from_site.pixels, sensor.acquire_from_pose(data, pose).pixels)


def test_groups_leave_geoms_out(motor_cell: Cell) -> None:
    cell = motor_cell
    data = cell.make_data()
    # Behind the robot's shoulder (at home): the robot hides the motor unless it is left out.
    direction = sphere_directions(40)[27]
    pose = Pose.look_at(cell.object_center + 0.45 * direction,
                        cell.object_center + [0.01, -0.02, 0.005])
    with_robot = DepthSensor(cell, resolution=(107, 75)).acquire_from_pose(data, pose)
    without_robot = DepthSensor(cell, resolution=(107, 75), groups=(0, 1)).acquire_from_pose(
        data, pose)
    assert len(with_robot) == 0 and len(without_robot) > 1000
    with pytest.raises(ValueError, match="leave out the object"):
        DepthSensor(cell, groups=(0, 2))


def test_segment_box_test_matches_dense_sampling_of_each_segment() -> None:
    """The slab test against a brute-force reference: points every 0.1 mm along each segment,
    one inside the box. Segments with a zero direction component (parallel to a face) included;
    those that only graze the box (within 0.1 mm) are left out as undecidable by sampling."""
    rng = np.random.default_rng(5)
    half = np.array([0.2, 0.1, 0.05])
    origin = np.array([0.05, -0.3, 0.02])
    # Half of them aimed at points in the box, half anywhere.
    directions = np.concatenate([rng.uniform(-half, half, (200, 3)) - origin,
                                 rng.normal(size=(200, 3))])
    directions[:50, 0] = 0.0  # parallel to the x faces, the origin between them
    directions[50:100, 2] = 0.0  # and to the z faces
    directions[200:250, 1] = 0.0  # parallel to the y faces, the origin outside them: no hit
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    length = rng.uniform(0.05, 0.8, 400)
    steps = np.linspace(0.0, 1.0, 8001)
    samples = origin + (steps[None, :, None] * length[:, None, None]) * directions[:, None, :]
    # The deepest sample of each segment: <= 0 inside the box.
    depth = np.min(np.max(np.abs(samples) - half, axis=2), axis=1)
    meets = depth <= 0.0
    decidable = np.abs(depth) > 1e-4
    assert meets[decidable].sum() > 50 and (~meets[decidable]).sum() > 50
    np.testing.assert_array_equal(
        _segments_meet_box(origin, directions, length, half)[decidable], meets[decidable])
