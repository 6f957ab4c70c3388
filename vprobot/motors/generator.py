"""Build starter-motor meshes from their parameters and write seeded motor sets to disk.

Frame of a built motor: the main axis runs along +x with the pinion at +x, the solenoid lies on
the +z side, units are metres and the axis-aligned bounding box is centred at the origin.
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import trimesh
from scipy.spatial import ConvexHull
from tqdm import tqdm

from vprobot.families.solids import (
    OVERLAP_M,
    circle,
    cylinder_x,
    polar,
    prism_x,
    revolve_x,
    toothed_outline,
)
from vprobot.files.atomic import atomic_output, batch_folder
from vprobot.motors.parameters import MotorParameters, sample_parameters

# Facets around the axis: enough for smooth-looking housings at ~6k faces per motor.
_SECTIONS_LARGE = 96
_SECTIONS_SMALL = 24


def _angles_clear_of_top(count: int) -> np.ndarray:
    """Evenly spaced angles in the y-z plane (0 = +y, 90 deg = +z) that straddle +z, so no
    bolt, hole or stud ends up under the solenoid; two of them lie on +-y."""
    return np.deg2rad(90 + (np.arange(count) + 0.5) * 360 / count)


def _housing(p: MotorParameters) -> trimesh.Trimesh:
    r, chamfer = p.housing_radius_m, 0.0015
    x0 = -p.housing_length_m
    profile = [(x0, 0), (x0, r - chamfer), (x0 + chamfer, r), (OVERLAP_M, r), (OVERLAP_M, 0)]
    return revolve_x(profile, _SECTIONS_LARGE)


def _end_cap(p: MotorParameters) -> trimesh.Trimesh:
    r = p.end_cap_radius_m
    x0 = -p.housing_length_m - p.end_cap_length_m
    fillet = min(0.35 * p.end_cap_length_m, 0.2 * r)
    t = np.linspace(0, np.pi / 2, 6)
    arc = zip(x0 + fillet * (1 - np.cos(t)), r - fillet * (1 - np.sin(t)), strict=True)
    x1 = -p.housing_length_m + OVERLAP_M
    return revolve_x([(x0, 0), *arc, (x1, r), (x1, 0)], _SECTIONS_LARGE)


def _brush_holder(p: MotorParameters) -> trimesh.Trimesh:
    depth = p.brush_holder_depth_m + OVERLAP_M
    x_rear = -p.housing_length_m - p.end_cap_length_m - p.brush_holder_depth_m
    box = trimesh.creation.box([depth, p.brush_holder_width_m, p.brush_holder_height_m])
    box.apply_translation([x_rear + depth / 2, 0, 0])
    return box


def _bolts(p: MotorParameters) -> list[trimesh.Trimesh]:
    r, head = p.bolt_radius_m, 1.6 * p.bolt_radius_m
    # Partly sunk into the housing so they read as ridges running along it.
    pitch = p.housing_radius_m + 0.3 * r
    x_head = -p.housing_length_m - p.end_cap_length_m + 0.001
    profile = [
        (-p.bolt_length_m, 0),
        (-p.bolt_length_m, head),
        (x_head, head),
        (x_head, r),
        (OVERLAP_M, r),
        (OVERLAP_M, 0),
    ]
    return [
        revolve_x(profile, _SECTIONS_SMALL, polar(pitch, a))
        for a in _angles_clear_of_top(p.bolt_count)
    ]


def _flange_outline(p: MotorParameters) -> np.ndarray:
    """Hub plus one ear per mounting hole, each ear the convex hull of the hub and a boss
    around its hole (straight tangent flanks), as a polygon star-shaped about the axis."""
    # Sampling the union's radial function gives one clean polygon; a boolean union of the
    # hulls would stack coincident hub edges, which leaves zero-volume slivers.
    angles = np.linspace(0, 2 * np.pi, 2 * _SECTIONS_LARGE, endpoint=False)
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    hub = circle(p.housing_radius_m + OVERLAP_M, _SECTIONS_LARGE)
    ear_radius = p.flange_radius_m - p.mounting_hole_pitch_radius_m
    radius = np.zeros(len(angles))
    for a in _angles_clear_of_top(p.mounting_hole_count):
        boss = circle(ear_radius, 32, polar(p.mounting_hole_pitch_radius_m, a))
        # Facets n . x <= d of the hull; along a direction u the boundary is at min d / (n . u).
        facets = ConvexHull(np.vstack([hub, boss])).equations
        cosines = directions @ facets[:, :2].T
        along = np.divide(
            -facets[:, 2], cosines, out=np.full_like(cosines, np.inf), where=cosines > 0
        )
        radius = np.maximum(radius, along.min(axis=1))
    return directions * radius[:, None]


def _flange(p: MotorParameters) -> trimesh.Trimesh:
    thickness = p.flange_thickness_m
    plate = prism_x(_flange_outline(p), (0, 0), 0, thickness)
    holes = [
        cylinder_x(
            p.mounting_hole_radius_m,
            -OVERLAP_M,
            thickness + OVERLAP_M,
            _SECTIONS_SMALL,
            polar(p.mounting_hole_pitch_radius_m, a),
        )
        for a in _angles_clear_of_top(p.mounting_hole_count)
    ]
    return trimesh.boolean.difference([plate, *holes], engine="manifold")


def _nose(p: MotorParameters) -> trimesh.Trimesh:
    x0, length = p.flange_thickness_m, p.nose_length_m
    base, tip = p.nose_base_radius_m, p.nose_tip_radius_m
    profile = [
        (x0 - OVERLAP_M, 0),
        (x0 - OVERLAP_M, base),
        (x0 + 0.15 * length, base),
        (x0 + 0.85 * length, tip),
        (x0 + 0.85 * length, 0.9 * tip),
        (x0 + length, 0.9 * tip),
        (x0 + length, 0),
    ]
    return revolve_x(profile, _SECTIONS_LARGE)


def _pinion(p: MotorParameters) -> trimesh.Trimesh:
    outline = toothed_outline(p.pinion_tooth_count, 0.82 * p.pinion_radius_m, p.pinion_radius_m)
    x0 = p.flange_thickness_m + p.nose_length_m
    return prism_x(outline, (0, 0), x0 - OVERLAP_M, x0 + p.pinion_length_m)


def _solenoid_rear_x(p: MotorParameters) -> float:
    return p.solenoid_offset_m - p.solenoid_length_m / 2


def _solenoid(p: MotorParameters) -> list[trimesh.Trimesh]:
    r, length = p.solenoid_radius_m, p.solenoid_length_m
    x0 = _solenoid_rear_x(p)
    x1 = x0 + length
    cap, chamfer, plunger = 0.18 * length, 0.002, 0.06 * length
    profile = [
        (x0, 0),
        (x0, 0.86 * r),
        (x0 + cap, 0.86 * r),
        (x0 + cap, r),
        (x1 - chamfer, r),
        (x1, r - chamfer),
        (x1, 0.4 * r),
        (x1 + plunger, 0.4 * r),
        (x1 + plunger, 0),
    ]
    body = revolve_x(profile, _SECTIONS_LARGE, (0, p.solenoid_height_m))
    # Mounting saddle from inside the housing up to the solenoid axis; never past the flange.
    saddle_x0 = p.solenoid_offset_m - 0.4 * length
    saddle_x1 = min(p.solenoid_offset_m + 0.4 * length, p.flange_thickness_m)
    saddle_z0 = 0.6 * p.housing_radius_m
    saddle = trimesh.creation.box([saddle_x1 - saddle_x0, 1.2 * r, p.solenoid_height_m - saddle_z0])
    saddle.apply_translation(
        [(saddle_x0 + saddle_x1) / 2, 0, (saddle_z0 + p.solenoid_height_m) / 2]
    )
    return [body, saddle]


def _terminals(p: MotorParameters) -> list[trimesh.Trimesh]:
    r, length = p.terminal_radius_m, p.terminal_length_m
    x_face = _solenoid_rear_x(p)
    x_nut = x_face - 0.35 * length
    hexagon = circle(1.8 * r, 6)
    parts = []
    for a in _angles_clear_of_top(p.terminal_count):
        dy, dz = polar(0.5 * p.solenoid_radius_m, a)
        centre = (dy, p.solenoid_height_m + dz)
        parts.append(cylinder_x(r, x_face - length, x_nut + 0.001, _SECTIONS_SMALL, centre))
        parts.append(prism_x(hexagon + np.asarray(centre), centre, x_nut, x_face + 0.001))
    return parts


def build_motor(params: MotorParameters) -> trimesh.Trimesh:
    """Build one closed starter-motor mesh from its 9 components.

    Args:
        params: Shape parameters.

    Returns:
        A single watertight mesh in metres, axis along +x, solenoid on +z, bounding box centred
        at the origin.

    Raises:
        RuntimeError: if the boolean union did not yield a closed solid.
    """
    parts = [
        _housing(params),
        _end_cap(params),
        _nose(params),
        _flange(params),
        *_solenoid(params),
        *_terminals(params),
        _brush_holder(params),
        *_bolts(params),
        _pinion(params),
    ]
    mesh = trimesh.boolean.union(parts, engine="manifold")
    if not mesh.is_watertight or mesh.volume <= 0 or mesh.body_count != 1:
        raise RuntimeError(f"motor union is not a single closed solid for {params}")
    mesh.apply_translation(-mesh.bounds.mean(axis=0))
    return mesh


def motor_rng(seed: int, index: int) -> np.random.Generator:
    """Random generator of motor `index` in the set `seed`, independent of the set's size."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(index,)))


def _write_atomic(path: Path, data: bytes) -> None:
    with atomic_output(path) as temporary:
        temporary.write_bytes(data)


def motor_stem(seed: int, index: int) -> str:
    """File name of motor `index` of the set `seed`, without suffix (`motor_0_007`): named by
    its seed, as `vprobot objects generate` names part instances, and as episode lists name a
    generated motor (`generated/motor_0_007.stl`)."""
    return f"motor_{seed}_{index:03d}"


def generate_motors(count: int, seed: int, out_dir: Path, progress: bool = True) -> list[Path]:
    """Generate a seeded set of motors as `motor_<seed>_<iii>.stl` (binary, metres) and
    `motor_<seed>_<iii>.json` (`motor_stem`).

    Motor i depends only on (seed, i), so a larger set extends a smaller one.

    Args:
        count: Number of motors, at least 1.
        seed: Non-negative seed of the set.
        out_dir: Directory to write to; created if missing.
        progress: Show a progress bar.

    Returns:
        The STL paths, in index order.

    Raises:
        ValueError: if count < 1 or seed < 0.
    """
    out_dir = batch_folder(out_dir, count, seed)
    paths = []
    for index in tqdm(range(count), desc="motors", unit="motor", disable=not progress):
        params = sample_parameters(motor_rng(seed, index))
        mesh = build_motor(params)
        stem = out_dir / motor_stem(seed, index)
        meta = {"seed": seed, "index": index, "parameters": asdict(params)}
        _write_atomic(stem.with_suffix(".stl"), trimesh.exchange.stl.export_stl(mesh))
        _write_atomic(stem.with_suffix(".json"), (json.dumps(meta, indent=2) + "\n").encode())
        paths.append(stem.with_suffix(".stl"))
    return paths


BUNDLED_SETS = (("train", 20, 0), ("test", 5, 1))
"""(folder, count, seed) of each bundled set of `assets/motors/`; the paper's 100 motors are
`count 100, seed 0`, so `train/` is their first 20."""


def generate_bundled_motors(root: Path, progress: bool = True) -> list[Path]:
    """Write the bundled sets (`BUNDLED_SETS`) into `root/train/` and `root/test/`, replacing
    files of the same name: with `root` the package's motors folder, byte-identical to the
    committed files.

    The bundled motors keep the names the episode lists and splits give them
    (`test/motor_000.stl`), from before files were named by their set's seed.

    Returns:
        The STL paths, set by set in index order.
    """
    paths = []
    for folder, count, seed in BUNDLED_SETS:
        for index, stl in enumerate(generate_motors(count, seed, root / folder, progress)):
            named = stl.with_stem(f"motor_{index:03d}")
            stl.with_suffix(".json").replace(named.with_suffix(".json"))
            paths.append(stl.replace(named))
    return paths
