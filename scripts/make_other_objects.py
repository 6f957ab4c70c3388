"""Make the non-motor test objects of the generalisation study (vprobot/assets/objects/).

None of them is a starter motor, and no agent is trained on them. Each tests something a motor
does not: `bracket` (an L-shaped sheet-metal part: large flat faces and a concave inner corner),
`torus` (a ring: a through hole whose inner surface only oblique views see), `pipe_tee` (a
T-fitting with flanges: branches pointing in three directions). All are closed, in metres, and
fit the cell (bounding-sphere radius below vprobot.fit's limit).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

OUT = Path(__file__).resolve().parent.parent / "vprobot" / "assets" / "objects"


Vec3 = tuple[float, float, float]


def _box(extents: Vec3, center: Vec3) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=extents,
                                transform=trimesh.transformations.translation_matrix(center))


def _cylinder(radius: float, height: float, axis: str, center: Vec3) -> trimesh.Trimesh:
    rotation = {"x": trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]),
                "y": trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]),
                "z": np.eye(4)}[axis]
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=48,
                                     transform=rotation)
    mesh.apply_translation(center)
    return mesh


def objects() -> dict[str, trimesh.Trimesh]:
    bracket = trimesh.boolean.union([_box((0.20, 0.07, 0.012), (0.0, 0.0, 0.0)),
                                     _box((0.012, 0.07, 0.12), (-0.094, 0.0, 0.054)),
                                     _box((0.05, 0.012, 0.05), (-0.07, 0.0, 0.025))])
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name, mesh in objects().items():
        assert mesh.is_watertight, name
        path = args.out / f"{name}.stl"
        mesh.export(path)
        radius = float(np.linalg.norm(mesh.extents) / 2)
        print(f"{path}: extents {np.round(mesh.extents, 3).tolist()} m, radius {radius:.3f} m")


if __name__ == "__main__":
    main()
