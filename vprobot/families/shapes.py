"""The bundled non-motor objects of the generalisation study (`vprobot/assets/objects/`, the
`shapes-v1` list): fixed shapes, no family, no seed, no parameters.

None of them is a starter motor, and no agent is trained on them. Each tests something a motor
does not: `bracket` (an L-shaped sheet-metal part: large flat faces and a concave inner corner),
`torus` (a ring: a through hole whose inner surface only oblique views see), `pipe_tee` (a
T-fitting with flanges: branches pointing in three directions). All are closed, in metres, and
fit the cell (bounding-sphere radius below vprobot.cell.fit's limit).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from vprobot.families.solids import box
from vprobot.files.atomic import atomic_output

Vec3 = tuple[float, float, float]


def _cylinder(radius: float, height: float, axis: str, center: Vec3) -> trimesh.Trimesh:
    # Not `solids.rod`, which turns a cylinder along y otherwise about its axis: other
    # vertices, other bytes than the committed files.
    rotation = {"x": trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]),
                "y": trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]),
                "z": np.eye(4)}[axis]
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=48,
                                     transform=rotation)
    mesh.apply_translation(center)
    return mesh


def bundled_shapes() -> dict[str, trimesh.Trimesh]:
    """Each bundled object by name (its file's stem)."""
    bracket = trimesh.boolean.union([box((0.20, 0.07, 0.012), (0.0, 0.0, 0.0)),
                                     box((0.012, 0.07, 0.12), (-0.094, 0.0, 0.054)),
                                     box((0.05, 0.012, 0.05), (-0.07, 0.0, 0.025))])
    torus = trimesh.creation.torus(major_radius=0.08, minor_radius=0.028,
                                   major_sections=64, minor_sections=24)
    tee = trimesh.boolean.union([
        _cylinder(0.03, 0.22, "x", (0.0, 0.0, 0.0)),
        _cylinder(0.03, 0.11, "y", (0.0, 0.055, 0.0)),
        _cylinder(0.05, 0.015, "x", (0.11, 0.0, 0.0)),
        _cylinder(0.05, 0.015, "x", (-0.11, 0.0, 0.0)),
        _cylinder(0.05, 0.015, "y", (0.0, 0.11, 0.0)),
    ])
    return {"bracket": bracket, "torus": torus, "pipe_tee": tee}


def write_bundled_shapes(out_dir: Path) -> list[Path]:
    """Write each bundled object as `out_dir/NAME.stl` (binary, metres; created if missing):
    with the package's objects folder, byte-identical to the committed files.

    Returns:
        The STL paths.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, mesh in bundled_shapes().items():
        path = out_dir / f"{name}.stl"
        with atomic_output(path) as temporary:
            temporary.write_bytes(trimesh.exchange.stl.export_stl(mesh))
        paths.append(path)
    return paths
