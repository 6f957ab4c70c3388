"""Tests of coverage tracking: ε-matching, monotonicity, full coverage, clouds and frames."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import trimesh
from helpers import make_scene
from scipy.spatial import cKDTree

from vprobot.cell.sensor import DepthSensor
from vprobot.coverage.ground_truth import GroundTruth
from vprobot.coverage.tracker import EPSILON_PER_SPACING, CoverageTracker, to_mesh_frame
from vprobot.geometry.poses import Pose, matrix_to_quat, rotation_about_z
from vprobot.geometry.viewsphere import sphere_directions

RADIUS = 0.08


def _sphere_gt(count: int = 2048) -> tuple[np.ndarray, float]:
    """Evenly spread points on the whole sphere and their mean nearest-neighbour distance."""
    points = RADIUS * sphere_directions(count)
    distances, _ = cKDTree(points).query(points, k=2)
    return points, float(distances[:, 1].mean())


def test_dense_views_all_around_a_convex_object_cover_everything() -> None:
    gt_points, spacing = _sphere_gt()
    scene, data = make_scene(trimesh.creation.icosphere(subdivisions=5, radius=RADIUS))
    sensor = DepthSensor(scene, resolution=(215, 150))
    tracker = CoverageTracker(gt_points, spacing)
    coverages = [0.0]
    for direction in sphere_directions(40):
        acquisition = sensor.acquire_from_pose(data, Pose.look_at(0.47 * direction, np.zeros(3)))
        step = tracker.update(acquisition.points_mesh, acquisition.sensor_pose)
        assert step.delta == pytest.approx(step.coverage - coverages[-1])
        assert step.remaining_before == pytest.approx(1.0 - coverages[-1])
        assert step.remaining == pytest.approx(1.0 - step.coverage)
        coverages.append(step.coverage)
    assert np.all(np.diff(coverages) >= 0) and max(coverages) <= 1.0
    assert coverages[1] < 0.5
    assert coverages[-1] >= 0.99
    assert sum(step.newly_covered for step in tracker.steps) == tracker.covered_count
    assert [step.step for step in tracker.steps] == list(range(1, 41))
    assert len(tracker.poses) == len(tracker.clouds) == 40


def test_matching_is_exact_within_epsilon() -> None:
    rng = np.random.default_rng(3)
    gt_points = rng.uniform(-0.05, 0.05, (500, 3))
    tracker = CoverageTracker(gt_points, spacing=0.01, epsilon=0.004)
    for _ in range(4):
        cloud = rng.uniform(-0.06, 0.06, (300, 3))
        before = tracker.covered
        step = tracker.update(cloud)
        near = (np.linalg.norm(gt_points[:, None] - cloud[None], axis=2) <= 0.004).any(axis=1)
        np.testing.assert_array_equal(tracker.covered, before | near)
        assert step.newly_covered == int((near & ~before).sum())
        np.testing.assert_array_equal(tracker.inverted_cloud, gt_points[~tracker.covered])


def test_epsilon_scales_with_the_spacing() -> None:
    gt_points, spacing = _sphere_gt(512)
    assert CoverageTracker(gt_points, spacing).epsilon == pytest.approx(
        EPSILON_PER_SPACING * spacing)
    assert CoverageTracker(gt_points, 2 * spacing).epsilon == pytest.approx(
        2 * EPSILON_PER_SPACING * spacing)


def test_accumulated_cloud_is_voxel_downsampled() -> None:
    rng = np.random.default_rng(4)
    tracker = CoverageTracker(rng.uniform(-0.05, 0.05, (100, 3)), spacing=0.01)
    first = rng.uniform(-0.05, 0.05, (2000, 3))
    second = rng.uniform(0.0, 0.1, (2000, 3))
    tracker.update(first)
    after_first = tracker.accumulated_cloud
    tracker.update(second)
    np.testing.assert_array_equal(tracker.previous_accumulated_cloud, after_first)
    accumulated = tracker.accumulated_cloud
    both = np.concatenate([first, second])
    voxels = np.unique(np.floor(both / 0.01), axis=0)
    assert len(accumulated) == len(voxels)
    # One centroid per voxel: the centroid lies in its voxel.
    np.testing.assert_array_equal(np.unique(np.floor(accumulated / 0.01), axis=0), voxels)


def test_empty_cloud_and_reset() -> None:
    gt_points, spacing = _sphere_gt(256)
    tracker = CoverageTracker(gt_points, spacing)
    step = tracker.update(np.zeros((0, 3)))
    assert step.coverage == 0.0 and step.delta == 0.0 and step.points == 0
    tracker.update(gt_points[:10])
    assert tracker.coverage == pytest.approx(10 / 256)
    tracker.reset()
    assert tracker.coverage == 0.0 and tracker.steps == [] and len(tracker.accumulated_cloud) == 0


def test_from_ground_truth_uses_its_voxel_size() -> None:
    gt_points, spacing = _sphere_gt(256)
    gt = GroundTruth(points=gt_points, spacing_m=spacing, voxel_size_m=1.5 * spacing,
                     mesh_hash="x", views=1)
    tracker = CoverageTracker.from_ground_truth(gt)
    assert tracker.voxel_size == 1.5 * spacing
    assert tracker.epsilon == pytest.approx(EPSILON_PER_SPACING * spacing)


def test_coverage_is_in_the_mesh_frame_of_a_turned_object() -> None:
    box = trimesh.creation.box((0.1, 0.06, 0.08))
    scene, data = make_scene(box)
    turn = rotation_about_z(np.pi / 2)
    data.mocap_quat[scene.model.body_mocapid[scene.object_body_id]] = matrix_to_quat(turn)
    mujoco.mj_kinematics(scene.model, data)
    # Seen from world +x, the turned box shows its mesh -y face.
    sensor = DepthSensor(scene, resolution=(107, 75))
    acquisition = sensor.acquire_from_pose(data, Pose.look_at([0.45, 0.0, 0.0], np.zeros(3)))
    np.testing.assert_allclose(acquisition.points_mesh[:, 1], -0.03, atol=1e-9)
    np.testing.assert_allclose(to_mesh_frame(acquisition.points_world, acquisition.object_pose),
                               acquisition.points_mesh)
    gt_points = np.array([[0.0, -0.03, 0.0], [0.0, 0.03, 0.0], [0.05, 0.0, 0.0]])
    tracker = CoverageTracker(gt_points, spacing=0.01)
    tracker.update(acquisition.points_mesh)
    np.testing.assert_array_equal(tracker.covered, [True, False, False])


@pytest.mark.parametrize(("points", "spacing", "epsilon", "message"), [
    (np.zeros((0, 3)), 0.01, None, "shape"),
    (np.zeros((5, 2)), 0.01, None, "shape"),
    (np.full((5, 3), np.nan), 0.01, None, "finite"),
    (np.zeros((5, 3)), 0.0, None, "spacing"),
    (np.zeros((5, 3)), 0.01, -1.0, "epsilon"),
])
def test_bad_arguments_are_rejected(points: np.ndarray, spacing: float, epsilon: float | None,
                                    message: str) -> None:
    with pytest.raises(ValueError, match=message):
        CoverageTracker(points, spacing, epsilon=epsilon)


def test_bad_cloud_is_rejected() -> None:
    tracker = CoverageTracker(np.zeros((5, 3)), 0.01)
    with pytest.raises(ValueError, match="shape"):
        tracker.update(np.zeros((4, 2)))
