"""Load a user-supplied object mesh (STL / OBJ / PLY, ...) as a repaired, centred mesh in metres."""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from vprobot.files.progress import note
from vprobot.parts.simplify import SIMPLIFIED_FACES, SIMPLIFY_ABOVE_FACES, Simplification, simplify

# Anything outside this is almost surely in the wrong unit rather than a real inspection object.
MIN_EXTENT_M = 0.01
MAX_EXTENT_M = 5.0

FLAT_TOLERANCE = 1e-6
"""A mesh thinner than this fraction of its largest side is flat: float32, MuJoCo's vertex type,
resolves about 6e-8 of a coordinate, so to MuJoCo's convex hull it is a plane."""

_FORMATS = "a mesh file trimesh can read (STL, OBJ, PLY, ...)"

# Files users mistake for meshes; a binary STL's 80-byte header is free text, so these are only
# looked for in files that are not well-formed binary STLs.
_NOT_MESH_SIGNATURES = (
    (b"\x89PNG\r\n\x1a\n", "a PNG image"),
    (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF87a", "a GIF image"),
    (b"GIF89a", "a GIF image"),
    (b"II*\x00", "a TIFF image"),
    (b"MM\x00*", "a TIFF image"),
    (b"%PDF-", "a PDF document"),
)
_STL_HEADER_BYTES, _STL_TRIANGLE_BYTES = 84, 50


@dataclass(frozen=True)
class LoadedMesh:
    """A mesh ready for the scene.

    Attributes:
        mesh: The repaired mesh in metres, its bounding box centred at the origin.
        offset: What was subtracted: ``mesh.vertices == file_vertices * scale - offset``.
        scale: Factor from file units to metres.
        path: The source file.
        mesh_hash: sha256 of the file bytes and the scale, to recognise the same object.
        repairs: What repairing changed, plus a "warning: ..." entry if it is still open.
        simplification: How a mesh above `SIMPLIFY_ABOVE_FACES` was simplified, else None
            (`mesh` is then the simplified copy).
    """

    mesh: trimesh.Trimesh
    offset: np.ndarray
    scale: float
    path: Path
    mesh_hash: str
    repairs: list[str]
    simplification: Simplification | None = None


def is_binary_stl(data: bytes) -> bool:
    """Whether the bytes are a binary STL whose size matches its triangle count."""
    if len(data) < _STL_HEADER_BYTES:
        return False
    count = int.from_bytes(data[80:_STL_HEADER_BYTES], "little")
    return len(data) == _STL_HEADER_BYTES + _STL_TRIANGLE_BYTES * count


def _check_kind(path: Path, data: bytes) -> None:
    """Reject files that are plainly not meshes before trimesh guesses at them.

    Without this, trimesh reads a non-UTF-8 file as text through charset_normalizer, which is
    not always installed, or returns an empty scene.
    """
    if path.suffix.lower() == ".stl" and is_binary_stl(data):
        return
    for signature, kind in _NOT_MESH_SIGNATURES:
        if data.startswith(signature):
            raise ValueError(f"{path} is {kind}, not {_FORMATS}")
    if path.suffix.lower() == ".stl":
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            raise ValueError(
                f"{path} is not {_FORMATS}: neither a binary STL (its size does not match its "
                f"triangle count) nor an ASCII STL"
            ) from None


def _read_mesh(path: Path) -> trimesh.Trimesh:
    try:
        # process=False keeps the file as is, so the repairs below can report what they did.
        loaded = trimesh.load(path, process=False)
    except ImportError as exc:
        raise ValueError(f"{path} is not {_FORMATS} (reading it needs the missing module "
                         f"{exc.name})") from exc
    except Exception as exc:
        raise ValueError(f"cannot read {path} as a mesh ({exc}); expected {_FORMATS}") from exc
    if isinstance(loaded, trimesh.Scene):
        if not loaded.geometry:
            raise ValueError(f"{path} holds no geometry: it is empty or not {_FORMATS}")
        loaded = loaded.to_mesh()
    if not isinstance(loaded, trimesh.Trimesh):
        raise ValueError(
            f"{path} holds a {type(loaded).__name__}, not a triangle mesh; expected {_FORMATS}"
        )
    return loaded


def solid_problem(mesh: trimesh.Trimesh) -> str | None:
    """What keeps a mesh with faces from being a solid object in the cell, or None.

    Returns:
        "has non-finite vertex coordinates ..." or "is flat: ...", to follow the mesh's name.
    """
    vertices = np.asarray(mesh.vertices, dtype=float)
    bad = int((~np.isfinite(vertices)).any(axis=1).sum())
    if bad:
        return (f"has non-finite vertex coordinates (NaN or inf) in {bad} of {len(vertices)} "
                f"vertices")
    used = vertices[np.unique(np.asarray(mesh.faces))] if len(mesh.faces) else vertices
    centred = used - used.mean(axis=0)
    # The least-variance direction of coplanar points is their plane's normal.
    normal = np.linalg.eigh(centred.T @ centred)[1][:, 0]
    thickness = float(np.ptp(centred @ normal))
    extent = float(np.ptp(used, axis=0).max())
    if thickness <= FLAT_TOLERANCE * extent:
        return (f"is flat: all vertices lie in one plane ({thickness:.3g} m thick over "
                f"{extent:.3g} m); vprobot needs a solid object")
    return None


def _repair(mesh: trimesh.Trimesh) -> list[str]:
    """Fix what trimesh can in place and describe each change."""
    repairs = []

    def record(what: str, count: int) -> None:
        if count:
            repairs.append(f"{what}: {count}")

    before = len(mesh.vertices)
    mesh.merge_vertices()
    record("merged duplicate vertices", before - len(mesh.vertices))
    keep = mesh.nondegenerate_faces()
    mesh.update_faces(keep)
    record("removed degenerate faces", int((~keep).sum()))
    before = len(mesh.faces)
    mesh.update_faces(mesh.unique_faces())
    record("removed duplicate faces", before - len(mesh.faces))
    before = len(mesh.vertices)
    mesh.remove_unreferenced_vertices()
    record("removed unreferenced vertices", before - len(mesh.vertices))
    if len(mesh.faces) and not mesh.is_watertight:
        before = len(mesh.faces)
        trimesh.repair.fill_holes(mesh)
        record("filled holes, faces added", len(mesh.faces) - before)
    if len(mesh.faces):
        faces_before = mesh.faces.copy()
        trimesh.repair.fix_normals(mesh, multibody=True)
        record("fixed winding / normals of faces",
               int((mesh.faces != faces_before).any(axis=1).sum()))
        if not mesh.is_watertight:
            open_edges = len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))
            repairs.append(
                f"warning: mesh is not watertight after repair ({open_edges} open edges);"
                " ray casts work but volume and inside tests are unreliable"
            )
    return repairs


def scale_setting(scale: float, option: str = "scale") -> str:
    """`scale` as the user sets it: `--scale 0.001` (an option), `env.mesh_scale=0.001` (a
    config key) or `scale=0.001` (a Python argument)."""
    return f"{option} {scale:g}" if option.startswith("--") else f"{option}={scale:g}"


def _unit_hint(file_extent: float, scale: float, option: str) -> str:
    """Suggest the scale that brings an out-of-range extent (`file_extent` in the file's units
    times `scale`) to a plausible object size."""
    extent = file_extent * scale
    if extent > MAX_EXTENT_M:
        for unit, factor in (("millimetres", 1e-3), ("centimetres", 1e-2), ("inches", 0.0254)):
            if 0.05 <= extent * factor <= 2.0:
                return f"looks like {unit}: use {scale_setting(scale * factor, option)}"
    # From the file's own extent: the scaled one may have overflowed to inf or lost its digits.
    suggested = 10.0 ** round(math.log10(0.2 / file_extent))
    return (f"set {option} to convert the file units to metres, e.g. "
            f"{scale_setting(suggested, option)}")


def _check_size(path: Path, mesh: trimesh.Trimesh, scale: float, option: str) -> None:
    """Refuse a mesh whose largest side times `scale` lies outside MIN_EXTENT_M .. MAX_EXTENT_M,
    naming the scale; checked before scaling, which a scale such as 1e308 or 1e-320 would turn
    into infinite or coinciding vertices (and an error about faces, not the scale)."""
    used = mesh.vertices[np.unique(mesh.faces)] if len(mesh.faces) else mesh.vertices
    file_extent = float(np.ptp(used, axis=0).max()) if len(used) else 0.0
    extent = file_extent * scale
    if file_extent > 0 and not MIN_EXTENT_M <= extent <= MAX_EXTENT_M:
        raise ValueError(
            f"{path}: largest side is {extent:.4g} m with {scale_setting(scale, option)}, "
            f"outside the allowed {MIN_EXTENT_M:g} .. {MAX_EXTENT_M:g} m; "
            f"{_unit_hint(file_extent, scale, option)}"
        )


def load_mesh(path: str | Path, scale: float = 1.0, scale_option: str = "scale") -> LoadedMesh:
    """Load, repair, scale to metres and centre a mesh file.

    Args:
        path: STL, OBJ, PLY or any other mesh file trimesh reads; a scene is merged into one mesh.
        scale: Factor from file units to metres, e.g. 0.001 for a file in millimetres.
        scale_option: How the user sets `scale` (`scale_setting`), for the hints.

    Returns:
        The loaded mesh with its offset, scale, hash and repair notes.

    Raises:
        FileNotFoundError: if the file does not exist.
        ValueError: if scale is not a positive finite number, the file is unreadable or not a
            mesh, has no faces or non-finite vertices, is flat, or its scaled extent is outside
            0.01 .. 5 m. Whether the object fits a cell is `vprobot.cell.fit.check_fits`.
    """
    path = Path(path)
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scale for {path} must be a positive finite number, got {scale!r}")
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not {_FORMATS}")
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}; expected {_FORMATS}")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"cannot read {path} ({exc}); expected {_FORMATS}") from exc
    _check_kind(path, data)
    mesh = _read_mesh(path)
    if not np.isfinite(mesh.vertices).all():
        # Repairing would quietly drop the faces at such vertices and patch the holes.
        raise ValueError(f"{path} {solid_problem(mesh)}")
    _check_size(path, mesh, scale, scale_option)
    mesh.apply_scale(scale)
    bounds = mesh.bounds
    simplification = None
    if len(mesh.faces) > SIMPLIFY_ABOVE_FACES:
        note(f"{path}: {len(mesh.faces):,} faces, simplifying to {SIMPLIFIED_FACES:,} for "
             f"planning ...")
        mesh.merge_vertices()
        mesh, simplification = simplify(mesh, SIMPLIFIED_FACES)
        note(f"{path}: {simplification.describe()}")
    repairs = _repair(mesh)
    if len(mesh.faces) == 0:
        raise ValueError(f"{path} contains no (non-degenerate) faces; expected {_FORMATS}")
    problem = solid_problem(mesh)
    if problem is not None:
        raise ValueError(f"{path} {problem}")

    # The original's box, so that the plan places the file as stored whatever was simplified.
    offset = bounds.mean(axis=0)
    mesh.apply_translation(-offset)
    mesh_hash = hashlib.sha256(data + f"|scale={scale!r}".encode()).hexdigest()
    return LoadedMesh(mesh, offset, float(scale), path, mesh_hash, repairs, simplification)
