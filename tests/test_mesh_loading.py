"""Tests of loading user-supplied object meshes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from vprobot.cell.scene import Cell
from vprobot.config import Config
from vprobot.parts.loading import load_mesh

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


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> Path:
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("suffix", [".stl", ".obj"])
@pytest.mark.parametrize(
    ("name", "vertices", "faces"),
    [
        ("triangle", [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], [[0, 1, 2]]),
        ("square", [[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]], [[0, 1, 2], [0, 2, 3]]),
    ],
)
def test_flat_meshes_are_rejected(tmp_path: Path, suffix: str, name: str,
                                  vertices: list[list[float]], faces: list[list[int]]) -> None:
    # Used to end in qhull's QhullError (triangle) or MuJoCo's "coplanar vertices" (square).
    path = tmp_path / f"{name}{suffix}"
    trimesh.Trimesh(vertices, faces, process=False).export(path)
    with pytest.raises(ValueError, match=rf"{name}\{suffix} is flat: all vertices lie in one plane"
                                         r".*needs a solid object$") as raised:
        load_mesh(path)
    assert str(path) in str(raised.value) and "\n" not in str(raised.value)


def test_thin_solid_plate_still_loads(tmp_path: Path) -> None:
    loaded = load_mesh(_box(tmp_path / "plate.stl", np.array([0.2, 0.15, 0.001])))
    np.testing.assert_allclose(loaded.mesh.extents, [0.2, 0.15, 0.001], atol=1e-6)


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_non_finite_vertices_are_rejected(tmp_path: Path, bad: float) -> None:
    # Repairing used to drop the faces at the NaN vertex and fill the hole: a silently other mesh.
    box = trimesh.creation.box(SIZE)
    vertices = box.vertices.copy()
    vertices[3, 1] = bad
    path = _write_obj(tmp_path / "broken.obj", vertices, box.faces)
    with pytest.raises(ValueError, match=r"broken\.obj has non-finite vertex coordinates"
                                         r" \(NaN or inf\) in 1 of 8 vertices$"):
        load_mesh(path)


def test_non_finite_vertices_in_binary_stl(tmp_path: Path) -> None:
    box = trimesh.creation.box(SIZE)
    triangles = box.vertices[box.faces].astype(np.float32)
    triangles[0, 0, 2] = np.nan
    record = np.zeros(len(triangles), dtype=[("normal", "<f4", 3), ("vertices", "<f4", (3, 3)),
                                             ("attributes", "<u2")])
    record["vertices"] = triangles
    path = tmp_path / "nan.stl"
    path.write_bytes(bytes(80) + np.uint32(len(triangles)).tobytes() + record.tobytes())
    with pytest.raises(ValueError, match=r"nan\.stl has non-finite vertex coordinates"):
        load_mesh(path)


def _png_bytes(tmp_path: Path) -> bytes:
    from PIL import Image

    Image.new("RGB", (16, 16), (200, 30, 30)).save(tmp_path / "image.png")
    return (tmp_path / "image.png").read_bytes()


@pytest.mark.parametrize("charset_normalizer", ["installed", "missing"])
@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
def test_image_renamed_as_mesh(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, suffix: str,
                               charset_normalizer: str) -> None:
    if charset_normalizer == "missing":
        # trimesh sniffs the text encoding with it, and it is not always installed.
        monkeypatch.setitem(sys.modules, "charset_normalizer", None)
    path = tmp_path / f"photo{suffix}"
    path.write_bytes(_png_bytes(tmp_path))
    with pytest.raises(ValueError, match=rf"^\S*photo\{suffix} is a PNG image, not a mesh file "
                                         r"trimesh can read \(STL, OBJ, PLY, \.\.\.\)$"):
        load_mesh(path)


def test_binary_junk_named_stl(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "charset_normalizer", None)
    path = tmp_path / "junk.stl"
    path.write_bytes(bytes(range(128, 256)) * 40)
    with pytest.raises(ValueError, match=r"junk\.stl is not a mesh file trimesh can read "
                                         r"\(STL, OBJ, PLY, \.\.\.\): neither a binary STL"):
        load_mesh(path)


def test_binary_stl_with_png_like_header_loads(tmp_path: Path) -> None:
    # A binary STL's header is free text: only its size decides what it is.
    path = _box(tmp_path / "box.stl")
    data = path.read_bytes()
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + data[8:])
    np.testing.assert_allclose(load_mesh(path).mesh.extents, SIZE, atol=1e-6)


def test_cell_rejects_flat_mesh_built_in_code() -> None:
    square = trimesh.Trimesh([[0, 0, 0], [0.1, 0, 0], [0.1, 0.1, 0], [0, 0.1, 0]],
                             [[0, 1, 2], [0, 2, 3]])
    with pytest.raises(ValueError, match=r"^object mesh is flat: all vertices lie in one plane"):
        Cell(Config(), square)
