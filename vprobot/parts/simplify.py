"""A simplified copy of a dense mesh for planning, with its measured distance to the original.

CAD exports of real parts carry 10^5 to 10^6 triangles, far finer than the sensor resolves: at
the working distance a pixel spans about 1.6 mm and coverage matches points within about 2 mm.
The sensor's scan conversion, the ground truth and the candidates' visibility all cost time per
triangle, so a mesh above `SIMPLIFY_ABOVE_FACES` is planned on a copy decimated to
`SIMPLIFIED_FACES` by quadric edge collapse (fast-simplification, the decimator trimesh itself
uses). How far the copy strays is measured, not assumed: the distance from a seeded sample of the
original's vertices to the copy's surface.
"""

from __future__ import annotations

import dataclasses

import fast_simplification
import numpy as np
import trimesh

SIMPLIFY_ABOVE_FACES = 200_000
"""Meshes with more faces are planned on a simplified copy."""
SIMPLIFIED_FACES = 100_000
"""Faces of the copy: the bundled motors' plans cost about 10 s at this size."""
DEVIATION_SAMPLES = 4096
"""Original vertices whose distance to the copy is measured."""


@dataclasses.dataclass(frozen=True)
class Simplification:
    """What simplifying a mesh did.

    Attributes:
        faces_before: Faces of the original (after merging duplicate vertices).
        faces_after: Faces of the copy.
        max_deviation_m: Largest distance from a sampled original vertex to the copy.
        mean_deviation_m: Mean of those distances.
    """

    faces_before: int
    faces_after: int
    max_deviation_m: float
    mean_deviation_m: float

    def describe(self) -> str:
        """One line for summaries: the face counts and the deviation in millimetres."""
        return (f"simplified from {self.faces_before:,} to {self.faces_after:,} faces for "
                f"planning (distance to the original: max {self.max_deviation_m * 1e3:.2f} mm, "
                f"mean {self.mean_deviation_m * 1e3:.3f} mm)")


def simplify(mesh: trimesh.Trimesh,
             faces: int = SIMPLIFIED_FACES) -> tuple[trimesh.Trimesh, Simplification]:
    """A copy of `mesh` decimated to about `faces` faces, and its measured deviation.

    Args:
        mesh: The original, vertices merged (quadric collapse needs shared vertices).
        faces: Faces of the copy.

    Raises:
        ValueError: If `faces` is below 4 or not below the mesh's face count.
    """
    if not 4 <= faces < len(mesh.faces):
        raise ValueError(f"faces must be at least 4 and below the mesh's {len(mesh.faces):,} "
                         f"faces, got {faces}")
    vertices, kept = fast_simplification.simplify(
        np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64),
        target_count=faces)
    copy = trimesh.Trimesh(vertices, kept, process=False)
    rng = np.random.default_rng(0)
    sample = rng.choice(len(mesh.vertices), size=min(DEVIATION_SAMPLES, len(mesh.vertices)),
                        replace=False)
    _, distances, _ = trimesh.proximity.closest_point(copy, mesh.vertices[sample])
    return copy, Simplification(faces_before=len(mesh.faces), faces_after=len(copy.faces),
                                max_deviation_m=float(distances.max()),
                                mean_deviation_m=float(distances.mean()))
