"""Tests of the ground-truth cloud: size, surface, inspectability, determinism and caching."""

from __future__ import annotations

import io
import os
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import trimesh

from vprobot.config import Config
from vprobot.coverage import ground_truth as gt_module
from vprobot.coverage.ground_truth import (
    N_GT,
    GroundTruth,
    build_ground_truth,
    default_cache_dir,
    ground_truth,
    mesh_hash,
)
from vprobot.files import atomic as files

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
    assert gt_module._read(tmp_path / f"{key}.npz", mesh_hash(box)) is not None


def _npz_bytes(**arrays: object) -> bytes:
    stream = io.BytesIO()
    np.savez(stream, **arrays)
    return stream.getvalue()


def _fields(gt: GroundTruth) -> dict[str, object]:
    return {"points": gt.points, "spacing_m": gt.spacing_m, "voxel_size_m": gt.voxel_size_m,
            "mesh_hash": gt.mesh_hash, "views": gt.views}


def _bad_entries(gt: GroundTruth) -> dict[str, bytes]:
    """Cache files that must not be taken for a GT, by what is wrong with them."""
    good = _npz_bytes(**_fields(gt))
    missing = _fields(gt)
    del missing["views"]
    return {
        "truncated": good[: len(good) // 2],
        "empty": b"",
        "random bytes": np.random.default_rng(0).bytes(4096),
        "npy instead of npz": np.save(stream := io.BytesIO(), gt.points) or stream.getvalue(),
        "missing key": _npz_bytes(**missing),
        "wrong shape": _npz_bytes(**{**_fields(gt), "points": gt.points[:100]}),
        "float32 points": _npz_bytes(**{**_fields(gt), "points": gt.points.astype(np.float32)}),
        "NaN point": _npz_bytes(**{**_fields(gt), "points": np.where(
            np.arange(N_GT)[:, None] == 7, np.nan, gt.points)}),
        "vector spacing": _npz_bytes(**{**_fields(gt), "spacing_m": np.ones(3)}),
        "other mesh": _npz_bytes(**{**_fields(gt), "mesh_hash": "0" * 64}),
    }


def _counting_build(monkeypatch: pytest.MonkeyPatch, gt: GroundTruth) -> list[int]:
    """Make `build_ground_truth` return `gt` (a fresh build) and count the calls."""
    calls: list[int] = []

    def build(mesh: trimesh.Trimesh, config: Config) -> GroundTruth:
        calls.append(1)
        return gt

    monkeypatch.setattr(gt_module, "build_ground_truth", build)
    return calls


def _assert_same(actual: GroundTruth, expected: GroundTruth) -> None:
    np.testing.assert_array_equal(actual.points, expected.points)
    assert actual.points.dtype == np.float64 and not actual.points.flags.writeable
    assert (actual.spacing_m, actual.voxel_size_m, actual.mesh_hash, actual.views) == (
        expected.spacing_m, expected.voxel_size_m, expected.mesh_hash, expected.views)


@pytest.mark.parametrize("kind", ["truncated", "empty", "random bytes", "npy instead of npz",
                                  "missing key", "wrong shape", "float32 points", "NaN point",
                                  "vector spacing", "other mesh"])
def test_bad_cache_file_is_recomputed_and_replaced(kind: str, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   box: trimesh.Trimesh,
                                                   box_gt: GroundTruth) -> None:
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    path = tmp_path / f"{gt_module._cache_key(box, Config())}.npz"
    path.write_bytes(_bad_entries(box_gt)[kind])
    calls = _counting_build(monkeypatch, box_gt)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _assert_same(ground_truth(box, Config(), cache_dir=tmp_path), box_gt)
    assert len(calls) == 1
    # Replaced by a good entry, without leftovers: the next process reads it back.
    assert sorted(tmp_path.iterdir()) == [path]
    stored = gt_module._read(path, mesh_hash(box))
    assert stored is not None
    _assert_same(stored, box_gt)
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    _assert_same(ground_truth(box, Config(), cache_dir=tmp_path), box_gt)
    assert len(calls) == 1


def _cache_dir_is_a_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    directory = tmp_path / "cache"
    directory.write_bytes(b"")
    return directory


def _cache_dir_below_a_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    (tmp_path / "cache").write_bytes(b"")
    return tmp_path / "cache" / "ground_truth"


def _read_only_cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    directory = tmp_path / "cache"
    directory.mkdir()
    directory.chmod(0o500)
    try:
        (directory / "probe").write_bytes(b"")
    except PermissionError:
        return directory
    # Root (or CAP_DAC_OVERRIDE) writes anyway: refuse the write the way the OS would.
    (directory / "probe").unlink()
    mkstemp = tempfile.mkstemp

    def refusing_mkstemp(*args: object, dir: str | Path | None = None,
                         **kwargs: object) -> tuple[int, str]:
        if dir is not None and Path(dir) == directory:
            raise PermissionError(13, "Permission denied", str(directory))
        return mkstemp(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", refusing_mkstemp)
    return directory


@pytest.mark.parametrize("make_dir", [_cache_dir_is_a_file, _cache_dir_below_a_file,
                                      _read_only_cache_dir],
                         ids=["is a file", "below a file", "read-only"])
def test_unwritable_cache_dir_warns_once_and_returns_the_gt(
        make_dir: Callable[[Path, pytest.MonkeyPatch], Path], tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch, box: trimesh.Trimesh, box_gt: GroundTruth) -> None:
    monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
    monkeypatch.setattr(files, "_WARNED_CACHE_DIRS", set())
    directory = make_dir(tmp_path, monkeypatch)
    # Through the environment, as most runs find their cache.
    monkeypatch.setenv("VPROBOT_CACHE_DIR", str(directory.parent))
    monkeypatch.setattr(gt_module, "default_cache_dir", lambda: directory)
    calls = _counting_build(monkeypatch, box_gt)
    try:
        with pytest.warns(RuntimeWarning) as record:
            _assert_same(ground_truth(box, Config()), box_gt)
            monkeypatch.setattr(gt_module, "_MEMORY_CACHE", {})
            _assert_same(ground_truth(box, Config(), cache_dir=directory), box_gt)
    finally:
        if directory.is_dir():
            directory.chmod(0o700)
    assert len(calls) == 2
    assert len(record) == 1, [str(warning.message) for warning in record]
    message = str(record[0].message)
    assert str(directory) in message and "not cached" in message
    assert record[0].filename == __file__
    assert not [name for name in os.listdir(tmp_path) if name.startswith(".")]


def test_mesh_without_faces_is_rejected() -> None:
    with pytest.raises(ValueError, match="no faces"):
        build_ground_truth(trimesh.Trimesh(), Config())
