"""Tests of the ground-truth cloud: size, surface, inspectability, determinism and caching."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from vprobot import ground_truth as gt_module
from vprobot.config import Config
from vprobot.ground_truth import (
    N_GT,
    GroundTruth,
    build_ground_truth,
    default_cache_dir,
    ground_truth,
    mesh_hash,
)

# A box whose footprint fits on the fixture plate (0.12 m x 0.08 m): its bottom face rests on it.
BOX_SIZE = np.array([0.10, 0.06, 0.08])


@pytest.fixture(scope="module")
def box() -> trimesh.Trimesh:
    return trimesh.creation.box(BOX_SIZE)


@pytest.fixture(scope="module")
def box_gt(box: trimesh.Trimesh) -> GroundTruth:
    return build_ground_truth(box, Config())


def test_exactly_n_gt_points_on_the_surface(box: trimesh.Trimesh, box_gt: GroundTruth) -> None:
    assert box_gt.points.shape == (N_GT, 3) == (2048, 3)
    assert len(np.unique(box_gt.points, axis=0)) == N_GT
    _, gap, _ = trimesh.proximity.closest_point(box, box_gt.points)
    assert gap.max() < 1e-6
    assert box_gt.mesh_hash == mesh_hash(box)
    assert not box_gt.points.flags.writeable


def test_resting_face_is_not_inspectable_but_the_rest_is(box_gt: GroundTruth) -> None:
    half = BOX_SIZE / 2
    on_face = np.abs(np.abs(box_gt.points) - half) < 1e-6
    inside_footprint = np.all(np.abs(box_gt.points[:, :2]) < half[:2] - 1e-4, axis=1)
    resting = on_face[:, 2] & (box_gt.points[:, 2] < 0) & inside_footprint
    assert not np.any(resting), "points on the resting face"
    # The other five faces share the points in proportion to their areas.
    faces = [(axis, sign) for axis in range(3) for sign in (-1, 1) if (axis, sign) != (2, -1)]
    areas = np.array([np.prod(np.delete(BOX_SIZE, axis)) for axis, _ in faces])
    counts = np.array([np.sum(on_face[:, axis] & (np.sign(box_gt.points[:, axis]) == sign))
                       for axis, sign in faces])
    np.testing.assert_allclose(counts / N_GT, areas / areas.sum(), atol=0.02)


def test_points_are_spread_evenly(box_gt: GroundTruth) -> None:
    from scipy.spatial import cKDTree

    distances, _ = cKDTree(box_gt.points).query(box_gt.points, k=2)
    nearest = distances[:, 1]
    # 2048 points on the 0.0412 m^2 of inspectable surface: about 4.5 mm apart.
    expected = np.sqrt((2 * np.prod(BOX_SIZE) * (1 / BOX_SIZE).sum()
                        - BOX_SIZE[0] * BOX_SIZE[1]) / N_GT)
    assert box_gt.spacing_m == pytest.approx(nearest.mean())
    assert 0.6 * expected < box_gt.spacing_m < 1.2 * expected
    assert nearest.max() < 2.5 * box_gt.spacing_m
    assert box_gt.voxel_size_m > box_gt.spacing_m


def test_deterministic(box: trimesh.Trimesh, box_gt: GroundTruth) -> None:
    again = build_ground_truth(box.copy(), Config())
    np.testing.assert_array_equal(again.points, box_gt.points)
    assert again.spacing_m == box_gt.spacing_m


def test_cached_in_memory_and_on_disk(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      box: trimesh.Trimesh, box_gt: GroundTruth) -> None:
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    first = ground_truth(box, Config(), cache_dir=tmp_path)
    files = list(tmp_path.glob("*.npz"))
    assert len(files) == 1 and files[0].name.startswith(mesh_hash(box)[:32])
    assert not list(tmp_path.glob("*.tmp"))
    np.testing.assert_array_equal(first.points, box_gt.points)
    assert ground_truth(box, Config(), cache_dir=tmp_path) is first

    def fail(*_: object) -> None:
        raise AssertionError("recomputed although cached on disk")

    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    monkeypatch.setattr(gt_module, "build_ground_truth", fail)
    from_disk = ground_truth(box, Config(), cache_dir=tmp_path)
    np.testing.assert_array_equal(from_disk.points, first.points)
    assert from_disk.spacing_m == first.spacing_m
    assert from_disk.voxel_size_m == first.voxel_size_m
    assert not from_disk.points.flags.writeable


def test_without_cache_nothing_is_stored(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                         box: trimesh.Trimesh) -> None:
    monkeypatch.setenv("VPROBOT_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(gt_module, "build_ground_truth",
                        lambda mesh, config: "computed")
    assert ground_truth(box, Config(), use_cache=False) == "computed"
    assert not any(tmp_path.rglob("*"))


def test_default_cache_dir(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("VPROBOT_CACHE_DIR", str(tmp_path))
    assert default_cache_dir() == tmp_path / "ground_truth"
    monkeypatch.delenv("VPROBOT_CACHE_DIR")
    assert default_cache_dir() == Path.home() / ".cache" / "vprobot" / "ground_truth"


def test_unreadable_cache_file_is_recomputed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             box: trimesh.Trimesh,
                                             box_gt: GroundTruth) -> None:
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    key = gt_module._cache_key(box, Config())
    (tmp_path / f"{key}.npz").write_bytes(b"not an npz")
    monkeypatch.setattr(gt_module, "build_ground_truth", lambda mesh, config: box_gt)
    assert ground_truth(box, Config(), cache_dir=tmp_path) is box_gt
    assert gt_module._read(tmp_path / f"{key}.npz") is not None


def test_mesh_without_faces_is_rejected() -> None:
    with pytest.raises(ValueError, match="no faces"):
        build_ground_truth(trimesh.Trimesh(), Config())
