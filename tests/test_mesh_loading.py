"""Tests of loading user-supplied object meshes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from vprobot.mesh_loading import load_mesh

CENTRE = np.array([1.0, 2.0, 3.0])
SIZE = np.array([0.2, 0.1, 0.05])


def _box(path: Path, size: np.ndarray = SIZE, centre: np.ndarray = CENTRE) -> Path:
    box = trimesh.creation.box(size)
    box.apply_translation(centre)
    box.export(path)
    return path


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
def test_load_centres_the_mesh(tmp_path: Path, suffix: str) -> None:
    path = _box(tmp_path / f"box{suffix}")
    loaded = load_mesh(path)
    np.testing.assert_allclose(loaded.mesh.bounds.mean(axis=0), 0, atol=1e-9)
    np.testing.assert_allclose(loaded.offset, CENTRE, atol=1e-6)
    np.testing.assert_allclose(loaded.mesh.extents, SIZE, atol=1e-6)
    assert loaded.mesh.is_watertight
    assert loaded.mesh.volume > 0
    assert loaded.path == path
    assert loaded.scale == 1.0
    assert not any(r.startswith("warning") for r in loaded.repairs)


def test_scale_converts_millimetres(tmp_path: Path) -> None:
    path = _box(tmp_path / "box_mm.stl", SIZE * 1000, CENTRE * 1000)
    with pytest.raises(ValueError, match=r"box_mm\.stl.*200 m.*millimetres: use scale=0\.001"):
        load_mesh(path)
    loaded = load_mesh(path, scale=0.001)
    np.testing.assert_allclose(loaded.mesh.extents, SIZE, atol=1e-6)
    np.testing.assert_allclose(loaded.offset, CENTRE, atol=1e-6)
    raw = trimesh.load(path, process=False)
    # centred = file_vertices * scale - offset, checked on one file vertex.
    assert np.isclose(
        np.linalg.norm(loaded.mesh.vertices - (raw.vertices[0] * 0.001 - loaded.offset), axis=1),
        0,
        atol=1e-9,
    ).any()


def test_hash_depends_on_bytes_and_scale(tmp_path: Path) -> None:
    path = _box(tmp_path / "box.stl")
    first = load_mesh(path)
    assert load_mesh(path).mesh_hash == first.mesh_hash
    assert load_mesh(path, scale=2.0).mesh_hash != first.mesh_hash
    assert len(first.mesh_hash) == 64


def test_scene_is_concatenated(tmp_path: Path) -> None:
    sphere = trimesh.creation.icosphere(radius=0.05)
    sphere.apply_translation([0.3, 0, 0])
    path = tmp_path / "scene.glb"
    trimesh.Scene([trimesh.creation.box([0.1] * 3), sphere]).export(path)
    loaded = load_mesh(path)
    assert len(loaded.mesh.faces) == 12 + len(sphere.faces)
    np.testing.assert_allclose(loaded.mesh.extents, [0.4, 0.1, 0.1], atol=1e-6)


def test_repairs_are_recorded(tmp_path: Path) -> None:
    box = trimesh.creation.box(SIZE)
    trimesh.Trimesh(box.vertices, box.faces[1:]).export(tmp_path / "hole.stl")
    holed = load_mesh(tmp_path / "hole.stl")
    assert holed.mesh.is_watertight
    assert any(r.startswith("filled holes") for r in holed.repairs)

    box.invert()
    box.export(tmp_path / "inverted.stl")
    inverted = load_mesh(tmp_path / "inverted.stl")
    assert inverted.mesh.volume > 0
    assert any("winding" in r for r in inverted.repairs)

    cylinder = trimesh.creation.cylinder(0.05, 0.2, sections=32)
    side = np.abs(cylinder.face_normals[:, 2]) < 0.5
    trimesh.Trimesh(cylinder.vertices, cylinder.faces[side]).export(tmp_path / "tube.stl")
    tube = load_mesh(tmp_path / "tube.stl")
    assert not tube.mesh.is_watertight
    assert any(r.startswith("warning: mesh is not watertight") for r in tube.repairs)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"nope\.stl.*STL, OBJ, PLY"):
        load_mesh(tmp_path / "nope.stl")


@pytest.mark.parametrize(
    ("name", "content"),
    [("empty.stl", ""), ("notes.txt", "not a mesh\n"), ("fake.stl", "hello, not a mesh\n")],
)
def test_files_that_are_not_meshes(tmp_path: Path, name: str, content: str) -> None:
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(ValueError, match=rf"{name.replace('.', '[.]')}.*STL, OBJ, PLY"):
        load_mesh(path)


def test_extent_too_small(tmp_path: Path) -> None:
    path = _box(tmp_path / "tiny.stl", np.full(3, 0.005))
    with pytest.raises(ValueError, match=r"tiny\.stl.*0\.005 m.*scale"):
        load_mesh(path)


@pytest.mark.parametrize("scale", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_scale(tmp_path: Path, scale: float) -> None:
    path = _box(tmp_path / "box.stl")
    with pytest.raises(ValueError, match=r"box\.stl.*positive finite"):
        load_mesh(path, scale=scale)
