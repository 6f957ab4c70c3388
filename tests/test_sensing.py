"""The structured-light sensing model against closed forms: incidence limits, the projector's
shadow, the noise law and the dropout law; and the ideal model left as it was.

Every reference is computed here from the documented laws and the pixel grid (ray-plane
intersections, similar triangles), not read back from the acquisition's code.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
import trimesh
from helpers import make_scene
from scipy.spatial import cKDTree

from vprobot.cell.sensor import LOSS_CAUSES, DepthSensor, FrameLosses
from vprobot.cli import main
from vprobot.config import (
    ConfigError,
    SensorConfig,
    load_config,
    replace,
    sensor_preset,
    with_sensing,
    with_sensor,
)
from vprobot.config.sensor import SensorModel
from vprobot.coverage.ground_truth import _cache_key, inspectable_points
from vprobot.coverage.occupancy import FREE, OCCUPIED, OccupancyGrid
from vprobot.coverage.tracker import CoverageTracker
from vprobot.files.paths import available_sensors
from vprobot.geometry.poses import Pose
from vprobot.sensing import IDEAL, IdealSensing, StructuredLight

CAMERA = SensorModel(resolution=(400, 300), fov_deg=(40.0, 30.0), near_m=0.2, far_m=0.8,
                     working_distance_m=0.5)
# Looking straight down from here: image x is world x, image y is world -y (test_sensor.py).
POSE = Pose.look_at([0.0013, -0.0007, 0.5], [0.0013, -0.0007, 0.0])
# A model that only does what a test switches on.
PLAIN = StructuredLight(baseline_m=1e-4, max_incidence_deg=90.0, projector_max_incidence_deg=90.0,
                        noise_sigma_m=0.0, noise_distance_m=0.5, dropout_grazing=0.0,
                        dropout_exponent=1.0)


def _in_world(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """`mesh`, given in the sensor frame of POSE, moved into the world."""
    placed = mesh.copy()
    transform = np.eye(4)
    transform[:3, :3], transform[:3, 3] = POSE.rotation, POSE.position
    placed.apply_transform(transform)
    return placed


def _tilted_sheet(tilt_deg: float, depth: float = 0.5) -> tuple[trimesh.Trimesh, np.ndarray]:
    """A 2 m square plate whose face towards the sensor passes through (0, 0, depth) of the
    sensor frame, turned by `tilt_deg` about the sensor's y axis; with the face's unit normal in
    the world."""
    plate = trimesh.creation.box((2.0, 2.0, 0.01))
    plate.apply_translation([0.0, 0.0, 0.005])
    turn = trimesh.transformations.rotation_matrix(math.radians(tilt_deg), [0.0, 1.0, 0.0])
    plate.apply_transform(turn)
    plate.apply_translation([0.0, 0.0, depth])
    return _in_world(plate), POSE.rotation @ turn[:3, 2]


def _rays_on_sheet(normal: np.ndarray, depth: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel of CAMERA: where its ray from POSE meets the sheet's plane, and its distance."""
    rays = CAMERA.ray_directions @ POSE.rotation.T
    on_plane = POSE.position + depth * POSE.rotation[:, 2]
    distance = ((on_plane - POSE.position) @ normal) / (rays @ normal)
    return POSE.position + rays * distance[:, None], distance


def _acquire(mesh: trimesh.Trimesh, sensing: StructuredLight | None,
             rng: np.random.Generator | None = None):
    scene, data = make_scene(mesh)
    sensor = DepthSensor(scene, CAMERA, sensing=sensing if sensing is not None else IDEAL)
    return sensor.acquire_from_pose(data, POSE, rng)


@pytest.mark.parametrize("ray", ["camera", "projector"])
@pytest.mark.parametrize("tilt_deg", [40.0, 45.0])
def test_tilted_plane_loses_its_points_exactly_past_the_incidence_limit(ray: str,
                                                                        tilt_deg: float) -> None:
    limit = 50.0
    baseline = 0.12
    model = dataclasses.replace(
        PLAIN, baseline_m=baseline,
        **{"max_incidence_deg" if ray == "camera" else "projector_max_incidence_deg": limit})
    mesh, normal = _tilted_sheet(tilt_deg)
    acquisition = _acquire(mesh, model)
    points, _ = _rays_on_sheet(normal)
    origin = POSE.position if ray == "camera" else POSE.position + baseline * POSE.rotation[:, 0]
    incoming = points - origin
    incidence = np.degrees(np.arccos(np.abs(incoming @ normal)
                                     / np.linalg.norm(incoming, axis=1)))
    # The frame spans the limit: the tilt puts it inside the image.
    assert incidence.min() < limit - 5 and incidence.max() > limit + 5
    # MuJoCo holds the plate in float32: its normal is the analytic one to about 1e-5 deg.
    clear = np.abs(incidence - limit) > 1e-3
    expected = np.flatnonzero((incidence <= limit) & clear)
    measured = acquisition.pixels[clear[acquisition.pixels]]
    np.testing.assert_array_equal(measured, expected)


STEP_BASELINE, STEP_DEPTH, STEP_HEIGHT, STEP_EDGE = 0.10, 0.5, 0.05, 0.01
"""The step edge's projector baseline b, floor depth D, block height h and edge x_e."""
STEP_SHADOW = (STEP_BASELINE - STEP_EDGE) * STEP_HEIGHT / (STEP_DEPTH - STEP_HEIGHT)
"""The width of the floor the block shadows (similar triangles)."""
STEP_PITCH = (2 * math.tan(math.radians(CAMERA.fov_deg[0] / 2)) / CAMERA.resolution[0]
              * STEP_DEPTH)
"""One camera pixel on the floor."""


def _step_edge() -> trimesh.Trimesh:
    """A floor at depth D with a block of height h on it, the block's edge facing the camera at
    x_e < b, in the sensor frame's x (moved into the world)."""
    floor = trimesh.creation.box((0.8, 0.6, 0.01))
    floor.apply_translation([0.0, 0.0, STEP_DEPTH + 0.005])
    block = trimesh.creation.box((0.2, 0.3, STEP_HEIGHT + 0.005))
    block.apply_translation([STEP_EDGE + 0.1, 0.0,
                             STEP_DEPTH - STEP_HEIGHT + (STEP_HEIGHT + 0.005) / 2])
    return _in_world(trimesh.util.concatenate([floor, block]))


def test_step_edge_casts_the_shadow_the_baseline_predicts() -> None:
    """A block of height h on a floor at depth D, its edge at x_e < b: the projector at x = b
    lights the floor past the edge only beyond x_e - (b - x_e) h / (D - h) (similar triangles),
    a shadow the camera at x = 0 sees whole."""
    baseline, depth, edge = STEP_BASELINE, STEP_DEPTH, STEP_EDGE
    mesh = _step_edge()
    ideal = _acquire(mesh, None)
    shadowed = _acquire(mesh, dataclasses.replace(PLAIN, baseline_m=baseline))
    local = (ideal.points_world - POSE.position) @ POSE.rotation
    # The floor's points along the block's middle, away from its ends.
    on_floor = (np.abs(local[:, 2] - depth) < 1e-6) & (np.abs(local[:, 1]) < 0.05)
    lost = on_floor & ~np.isin(ideal.pixels, shadowed.pixels)
    predicted, pitch = STEP_SHADOW, STEP_PITCH
    assert predicted > 10 * pitch
    # Every lost floor point lies in the predicted band, and the band is lost whole, to within
    # the sampling: half a projector pixel (one camera pixel: the projector's depth map has half
    # the camera's resolution) and one camera pixel.
    slack = 2 * pitch
    band = (local[:, 0] >= edge - predicted) & (local[:, 0] <= edge)
    assert np.all(band[lost] | (np.abs(local[lost, 0] - (edge - predicted)) < slack))
    kept_in_band = on_floor & band & ~lost
    assert np.all(np.abs(local[kept_in_band, 0] - (edge - predicted)) < slack)
    rows = np.unique(ideal.pixels[lost] // CAMERA.resolution[0])
    assert len(rows) > 50
    widths = [np.ptp(local[lost & (ideal.pixels // CAMERA.resolution[0] == row), 0]) + pitch
              for row in rows]
    assert np.mean(widths) == pytest.approx(predicted, abs=slack)
    # Off the floor only the wall facing away from the projector is lost: the block's top is lit.
    top = np.abs(local[:, 2] - (depth - STEP_HEIGHT)) < 1e-6
    assert np.isin(ideal.pixels[top], shadowed.pixels).all()


def _losses(mesh: trimesh.Trimesh, sensing: StructuredLight | IdealSensing) -> FrameLosses:
    scene, data = make_scene(mesh)
    return DepthSensor(scene, CAMERA, sensing=sensing).losses_from_pose(data, POSE)


def test_lost_points_are_shadowed_in_the_step_edges_shadow_and_grazing_past_the_limit() -> None:
    """The step edge under a camera incidence limit of 20 deg: the floor band the baseline
    predicts, and the block's wall towards the camera (seen at about 89 deg, but lit by the
    projector from behind: shadowed comes first), are shadowed; elsewhere a point of the floor
    or the block's top (horizontal: its incidence is its ray's angle to the optical axis) is
    grazing past 20 deg and measured within."""
    limit = 20.0
    mesh = _step_edge()
    losses = _losses(mesh, dataclasses.replace(PLAIN, baseline_m=STEP_BASELINE,
                                               max_incidence_deg=limit))
    ideal = losses.ideal
    np.testing.assert_array_equal(ideal.pixels, _acquire(mesh, None).pixels)
    cause = np.array(["measured", *LOSS_CAUSES])[losses.cause + 1]
    local = (ideal.points_world - POSE.position) @ POSE.rotation
    floor = np.abs(local[:, 2] - STEP_DEPTH) < 1e-6
    horizontal = floor | (np.abs(local[:, 2] - (STEP_DEPTH - STEP_HEIGHT)) < 1e-6)
    # The rest is the wall x = x_e: the block's other walls face away from the camera.
    assert np.all(np.abs(local[~horizontal, 0] - STEP_EDGE) < 1e-6)
    assert np.all(cause[~horizontal] == "shadowed") and np.sum(~horizontal) > 100
    slack = 2 * STEP_PITCH
    band = (floor & (np.abs(local[:, 1]) < 0.1)
            & (local[:, 0] > STEP_EDGE - STEP_SHADOW + slack) & (local[:, 0] < STEP_EDGE - slack))
    assert np.all(cause[band] == "shadowed") and np.sum(band) > 1000
    # Clear of the shadow: before its edge, beyond the block's ends (|y| <= 0.15, widened by
    # D / (D - h) on the floor), or on the block's top.
    clear = horizontal & ((local[:, 0] < STEP_EDGE - STEP_SHADOW - slack)
                          | (np.abs(local[:, 1]) > 0.2) | ~floor)
    incidence = np.degrees(np.arccos(local[:, 2] / np.linalg.norm(local, axis=1)))
    beyond, within = incidence > limit + 1e-3, incidence < limit - 1e-3
    assert np.all(cause[clear & beyond] == "grazing") and np.sum(clear & beyond) > 1000
    assert np.all(cause[clear & within] == "measured") and np.sum(clear & within) > 1000
    assert not np.any((cause == "grazing") & within)
    assert losses.counts()["dropped out"] == 0


def test_lost_points_are_what_each_reduction_of_the_model_drops_first() -> None:
    """The projector alone, its limits and the whole model (dropout, noise) each keep a subset
    of the one before's pixels; a lost point's cause is the step that dropped it, and the
    measured points are the model's own frame."""
    model = dataclasses.replace(PLAIN, baseline_m=STEP_BASELINE, max_incidence_deg=20.0,
                                noise_sigma_m=0.001, dropout_grazing=0.5, dropout_exponent=1.0)
    mesh = _step_edge()
    losses = _losses(mesh, model)
    kept = [losses.ideal.pixels] + [_acquire(mesh, stage).pixels for stage in
                                    (model.shadow_only(), model.limits_only(), model)]
    counts = losses.counts()
    for index, (before, after) in enumerate(itertools.pairwise(kept)):
        assert np.isin(after, before).all()
        np.testing.assert_array_equal(losses.ideal.pixels[losses.cause == index],
                                      np.setdiff1d(before, after))
        assert counts[LOSS_CAUSES[index]] == len(before) - len(after) > 100
    np.testing.assert_array_equal(losses.ideal.pixels[losses.cause == -1], kept[-1])
    assert counts["measured"] == len(kept[-1])


def test_nothing_is_lost_under_the_ideal_model() -> None:
    mesh = _step_edge()
    losses = _losses(mesh, IDEAL)
    ideal = _acquire(mesh, None)
    np.testing.assert_array_equal(losses.ideal.points_world, ideal.points_world)
    assert losses.counts() == {"measured": len(ideal), "shadowed": 0, "grazing": 0,
                               "dropped out": 0}


@pytest.mark.parametrize("kind", ["primitive", "mesh"])
def test_plate_before_the_projector_shadows_what_the_camera_sees(kind: str) -> None:
    """A plate outside the camera's view, in the projector's light: the fixture (a primitive,
    cast by MuJoCo) and the robot (meshes, in the projector's depth map) shadow the object."""
    baseline = 0.10
    floor = trimesh.creation.box((0.8, 0.6, 0.01))
    floor.apply_translation([0.0, 0.0, 0.505])
    mesh = _in_world(floor)
    # Sensor frame (x, y, z) is world (x, -y, -z) about POSE: the plate spans x 0.10 - 0.14 at
    # depth 0.25, beyond the camera's half-angle tangent (0.364) but before the projector.
    center, half = (0.12, 0.0, 0.25), (0.02, 0.03, 0.002)
    plate = (POSE.position + POSE.rotation @ np.array(center), half)
    plain_scene, plain_data = make_scene(mesh)
    scene, data = make_scene(mesh, **{"boxes" if kind == "primitive" else "mesh_boxes": [plate]})
    ideal = DepthSensor(plain_scene, CAMERA, sensing=IDEAL).acquire_from_pose(plain_data, POSE)
    camera_only = DepthSensor(scene, CAMERA, sensing=IDEAL).acquire_from_pose(data, POSE)
    np.testing.assert_array_equal(camera_only.pixels, ideal.pixels)
    model = dataclasses.replace(PLAIN, baseline_m=baseline)
    shadowed = DepthSensor(scene, CAMERA, sensing=model).acquire_from_pose(data, POSE)
    # Reference: the segment from the projector to the point crosses the plate's top or bottom.
    local = (ideal.points_world - POSE.position) @ POSE.rotation
    light = local - [baseline, 0.0, 0.0]
    expected_lost = np.zeros(len(local), dtype=bool)
    for depth in (center[2] - half[2], center[2] + half[2]):
        crossing = light * (depth / light[:, 2])[:, None]
        expected_lost |= ((np.abs(crossing[:, 0] + baseline - center[0]) <= half[0])
                          & (np.abs(crossing[:, 1] - center[1]) <= half[1]))
    assert expected_lost.sum() > 1000
    lost = ~np.isin(ideal.pixels, shadowed.pixels)
    if kind == "primitive":
        np.testing.assert_array_equal(lost, expected_lost)
    else:
        # The depth map's pixels are twice the camera's: its edges move by up to one of them.
        assert np.sum(lost != expected_lost) < 0.05 * expected_lost.sum()


def test_noise_on_a_plane_matches_sigma_within_five_percent() -> None:
    model = dataclasses.replace(PLAIN, noise_sigma_m=0.0005, noise_distance_m=0.45)
    mesh, normal = _tilted_sheet(35.0)
    acquisition = _acquire(mesh, model, np.random.default_rng(3))
    points, distance = _rays_on_sheet(normal)
    pixels = acquisition.pixels
    assert len(pixels) >= 100_000
    rays = CAMERA.ray_directions[pixels] @ POSE.rotation.T
    offsets = acquisition.points_world - POSE.position
    measured = np.linalg.norm(offsets, axis=1)
    # Along the camera ray, and only along it.
    np.testing.assert_allclose(offsets / measured[:, None], rays, atol=1e-9)
    depth = (points[pixels] - POSE.position) @ POSE.rotation[:, 2]
    cos_incidence = np.abs(rays @ normal)
    sigma = 0.0005 * (depth / 0.45) ** 2 / cos_incidence
    residual = measured - distance[pixels]
    assert np.std(residual / sigma) == pytest.approx(1.0, abs=0.05)
    assert abs(np.mean(residual / sigma)) < 0.02
    assert np.std(residual) == pytest.approx(np.sqrt(np.mean(sigma**2)), rel=0.05)


def test_dropout_rate_matches_its_law_within_one_point() -> None:
    model = dataclasses.replace(PLAIN, dropout_grazing=0.6, dropout_exponent=2.0)
    mesh, normal = _tilted_sheet(50.0)
    ideal = _acquire(mesh, None)
    acquisition = _acquire(mesh, model, np.random.default_rng(5))
    assert len(ideal) >= 100_000
    rays = CAMERA.ray_directions[ideal.pixels] @ POSE.rotation.T
    incidence = np.arccos(np.abs(rays @ normal))
    probability = 0.6 * (incidence / (math.pi / 2)) ** 2
    dropped = ~np.isin(ideal.pixels, acquisition.pixels)
    assert dropped.mean() == pytest.approx(probability.mean(), abs=0.01)
    # And across the frame's incidences (from about 30 to 70 degrees), quarter by quarter.
    quarters = np.array_split(np.argsort(incidence), 4)
    for quarter in quarters:
        assert dropped[quarter].mean() == pytest.approx(probability[quarter].mean(), abs=0.01)
    assert probability[quarters[-1]].mean() - probability[quarters[0]].mean() > 0.1


def test_noise_and_dropout_are_reproducible() -> None:
    model = dataclasses.replace(PLAIN, noise_sigma_m=0.001, dropout_grazing=0.5)
    mesh, _ = _tilted_sheet(30.0)
    scene, data = make_scene(mesh)
    sensor = DepthSensor(scene, CAMERA, sensing=model)
    first, again = (sensor.acquire_from_pose(data, POSE) for _ in range(2))
    # Without a generator: the frame's own draws, the same every time.
    np.testing.assert_array_equal(first.points_world, again.points_world)
    seeded = [sensor.acquire_from_pose(data, POSE, np.random.default_rng(seed))
              for seed in (1, 1, 2)]
    np.testing.assert_array_equal(seeded[0].points_world, seeded[1].points_world)
    assert not np.array_equal(seeded[0].pixels, seeded[2].pixels)


def test_ideal_model_draws_nothing_and_measures_as_before() -> None:
    mesh, _ = _tilted_sheet(30.0)
    scene, data = make_scene(mesh)
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    ideal = DepthSensor(scene, CAMERA, sensing=IDEAL).acquire_from_pose(data, POSE, rng)
    assert rng.bit_generator.state == state
    default = DepthSensor(scene, CAMERA).acquire_from_pose(data, POSE)
    np.testing.assert_array_equal(ideal.pixels, default.pixels)
    np.testing.assert_array_equal(ideal.points_world, default.points_world)


@pytest.mark.parametrize(("change", "key"), [
    ({"baseline_m": 0.0}, "baseline_m"),
    ({"max_incidence_deg": 95.0}, "max_incidence_deg"),
    ({"projector_max_incidence_deg": 0.0}, "projector_max_incidence_deg"),
    ({"noise_sigma_m": -1e-4}, "noise_sigma_m"),
    ({"dropout_grazing": 1.5}, "dropout_grazing"),
    ({"dropout_exponent": float("nan")}, "dropout_exponent"),
])
def test_bad_structured_light_figures_are_rejected(change: dict, key: str) -> None:
    with pytest.raises(ConfigError, match=f"sensor.structured_light.{key}"):
        dataclasses.replace(PLAIN, **change)


DEFAULT_SENSING = {"paper": "ideal", "phoxi_m": "structured_light",
                   "zivid2plus_mr60": "structured_light"}
"""The paper's sensor is ideal, as in the paper; the real devices are structured-light ones."""


def test_real_presets_default_to_structured_light_and_the_paper_to_ideal() -> None:
    for name, sensing in DEFAULT_SENSING.items():
        assert sensor_preset(name).sensing == sensing
    assert sensor_preset("paper").sensing_model is IDEAL
    config = with_sensor(load_config(), "zivid2plus_mr60")
    assert with_sensing(config, "ideal").sensor.sensing_model is IDEAL
    model = config.sensor.sensing_model
    assert isinstance(model, StructuredLight)
    # The Zivid 2+ M60 datasheet figure issue 31 quotes: 0.08 mm at 600 mm.
    assert (model.noise_sigma_m, model.noise_distance_m) == (0.00008, 0.60)
    # The simulator's PhoXi M baseline.
    assert sensor_preset("phoxi_m").structured_light.baseline_m == 0.35
    with pytest.raises(ConfigError, match="structured_light"):
        SensorConfig(sensing="structured_light")
    with pytest.raises(ConfigError, match="must be one of"):
        SensorConfig(sensing="laser")


def test_ground_truth_key_follows_the_models_limits_not_its_noise(cube) -> None:
    """The GT is measured with the model's deterministic limits, so its key changes with them
    and not with noise or dropout; the ideal key stays the old one (`test_results_regenerate`
    reads the committed tables' GTs through it)."""
    config = with_sensing(with_sensor(load_config(), "zivid2plus_mr60"), "ideal")
    light = with_sensing(config, "structured_light")
    figures = dataclasses.asdict(light.sensor.structured_light)
    noisier = replace(light, "sensor", structured_light={**figures, "noise_sigma_m": 0.001,
                                                         "dropout_grazing": 0.9})
    wider = replace(light, "sensor", structured_light={**figures, "baseline_m": 0.2})
    assert _cache_key(cube, light) == _cache_key(cube, noisier)
    assert len({_cache_key(cube, config), _cache_key(cube, light), _cache_key(cube, wider)}) == 3


def _mushroom() -> tuple[trimesh.Trimesh, float]:
    """A 0.2 m square cap, 0.03 m thick, on a 0.04 m column (0.18 m high in all, centred); and
    the height of the cap's underside. No GT view (at most 30 deg below the equator, 0.6 m from
    the centre) meets the underside at less than about 50 deg of incidence."""
    column = trimesh.creation.box((0.04, 0.04, 0.15))
    cap = trimesh.creation.box((0.2, 0.2, 0.03))
    cap.apply_translation([0.0, 0.0, 0.09])
    mesh = trimesh.util.concatenate([column, cap])
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    return mesh, float(mesh.bounds[1, 2]) - 0.03


def test_ground_truth_under_structured_light_is_what_its_limits_let_some_view_measure() -> None:
    config = with_sensing(with_sensor(load_config(), "zivid2plus_mr60"), "structured_light")
    figures = dataclasses.asdict(config.sensor.structured_light)
    limited = replace(config, "sensor", structured_light={**figures, "max_incidence_deg": 40.0})
    mesh, underside = _mushroom()
    ideal, _ = inspectable_points(mesh, with_sensing(config, "ideal"))
    light, _ = inspectable_points(mesh, limited)

    def on_underside(points: np.ndarray) -> np.ndarray:
        return ((np.abs(points[:, 2] - underside) < 1e-4)
                & (np.abs(points[:, :2]).max(axis=1) > 0.03)
                & (np.abs(points[:, :2]).max(axis=1) < 0.099))

    # The ideal views see the underside; under a 40 deg camera limit no view measures it.
    assert on_underside(ideal).sum() > 1000
    assert not on_underside(light).any()
    # Without noise every point is one an ideal view measured, exactly there; the baseline's
    # shadow and the incidence limits leave out more than the underside.
    assert len(light) < len(ideal) - on_underside(ideal).sum()
    assert np.isin(light.view("V24"), ideal.view("V24")).all()


def test_epsilon_marks_what_a_noisy_frame_measured_at_the_far_end_of_the_range() -> None:
    """With the Zivid preset's sigma at the far end of its range (incidences up to the 70 deg
    limit: up to 0.8 mm, ε / 2.5), the ε-test marks at least 99 % of the GT points the
    noise-free frame covers, and none that lies beyond 2 ε of it (past the incidence limit)."""
    preset = sensor_preset("zivid2plus_mr60")
    camera = SensorModel.from_config(preset).at_resolution((612, 512))
    model = dataclasses.replace(preset.structured_light, baseline_m=1e-4, dropout_grazing=0.0)
    depth = 1.05
    mesh, normal = _tilted_sheet(60.0, depth)
    scene, data = make_scene(mesh)
    noisy = DepthSensor(scene, camera, sensing=model).acquire_from_pose(data, POSE)
    exact = DepthSensor(scene, camera, sensing=model.limits_only()).acquire_from_pose(data, POSE)
    np.testing.assert_array_equal(noisy.pixels, exact.pixels)
    offsets = np.linalg.norm(noisy.points_world - exact.points_world, axis=1)
    sigma_max = model.noise_sigma(np.array(preset.far_m), np.cos(np.radians(70.0)))
    assert offsets.max() > 2.0 * sigma_max / 3
    # GT points 4.5 mm apart on the sheet (the bundled motors' spacing), where the frame looks.
    spacing = 0.0045
    grid = np.arange(-0.6, 0.6, spacing)
    across = np.cross(normal, POSE.rotation[:, 1])
    across /= np.linalg.norm(across)
    along = np.cross(normal, across)
    centre = POSE.position + depth * POSE.rotation[:, 2]
    gt = (centre + grid[:, None, None] * across + grid[None, :, None] * along).reshape(-1, 3)
    tracker = CoverageTracker(gt, spacing)
    assert tracker.epsilon >= 2.5 * sigma_max
    truly = tracker.match(exact.points_world)
    marked = tracker.match(noisy.points_world)
    assert truly.sum() > 5000
    assert marked[truly].mean() >= 0.99
    beyond = cKDTree(exact.points_world).query(gt)[0] > 2.0 * tracker.epsilon
    assert beyond.sum() > 1000
    assert not np.any(marked & beyond)


def test_occupancy_grid_integrates_a_noisy_frame_as_the_noise_free_one() -> None:
    """The grid's voxels (10 mm) and its free space, which stops half a voxel short of a point,
    dwarf the noise (sigma well under 1 mm here): a noisy frame marks the same voxels occupied but
    for a few at voxel boundaries, and frees none of the ones the noise-free frame marks."""
    model = dataclasses.replace(PLAIN, noise_sigma_m=0.0005, noise_distance_m=0.5)
    mesh, _ = _tilted_sheet(40.0)
    scene, data = make_scene(mesh)
    states = []
    for sensing in (model, model.limits_only()):
        frame = DepthSensor(scene, CAMERA, sensing=sensing).acquire_from_pose(data, POSE)
        grid = OccupancyGrid.around(POSE.position + 0.5 * POSE.rotation[:, 2], 0.15)
        grid.integrate(CAMERA, POSE, frame.points_world, frame.pixels, frame.blocked_pixels)
        states.append(grid.state)
    noisy, exact = states
    assert (exact == OCCUPIED).sum() > 500
    assert np.mean(noisy[exact == OCCUPIED] == OCCUPIED) > 0.97
    assert not np.any(noisy[exact == OCCUPIED] == FREE)


@pytest.fixture
def cube() -> trimesh.Trimesh:
    return trimesh.creation.box((0.1, 0.1, 0.1))


def test_sensing_option_without_figures_is_one_line(capsys: pytest.CaptureFixture) -> None:
    assert main(["plan", "--sensing", "structured_light", "--out", "unused.json"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert "--sensing" in line and "structured_light" in line


def test_sensors_lists_each_presets_model_and_sources(capsys: pytest.CaptureFixture) -> None:
    assert main(["sensors"]) == 0
    header, *lines = capsys.readouterr().out.splitlines()
    assert "sensing" in header and "sources" in header
    rows = {line.split()[0]: line for line in lines}
    assert list(rows) == available_sensors()
    for name, sensing in DEFAULT_SENSING.items():
        assert rows[name].endswith(f"configs/sensors/{name}.yaml")
        assert f" {sensing} " in rows[name]
    assert (header.index("sensing") == rows["paper"].index("ideal")
            == rows["zivid2plus_mr60"].index("structured_light"))
    assert "350 mm, 70 / 70 deg, 0.062 mm at 0.788 m, 0.5 (theta / 90 deg)^4" in rows["phoxi_m"]
    assert "150 mm" in rows["zivid2plus_mr60"] and "0.08 mm at 0.6 m" in rows["zivid2plus_mr60"]
