"""Solid primitives that the part generators (motors and the part families) build from.

All return closed trimesh meshes in metres; booleans over them use trimesh's manifold3d engine.
Revolved and prismatic parts run along x, as the motors do; anything else is placed by the
segment between two points.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import trimesh
from numpy.typing import ArrayLike

OVERLAP_M = 0.002
"""Parts reach this far into their neighbour so unions never meet on coplanar faces."""

Point = Sequence[float] | np.ndarray


def revolve_x(
    profile: Sequence[tuple[float, float]], sections: int, centre_yz: tuple[float, float] = (0, 0)
) -> trimesh.Trimesh:
    """Solid of revolution about an axis parallel to x.

    Args:
        profile: (x, radius) points by increasing x, starting and ending on the axis (radius 0).
        sections: Facets around the axis.
        centre_yz: Where the axis crosses the y-z plane.
    """
    # trimesh revolves (radius, height) about z; a +90 degree turn about y takes z to x.
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])
    turn[1:3, 3] = centre_yz
    return trimesh.creation.revolve([(r, x) for x, r in profile], sections=sections, transform=turn)


def prism_x(
    polygon_yz: np.ndarray, centre_yz: tuple[float, float], x0: float, x1: float
) -> trimesh.Trimesh:
    """Closed prism from x0 to x1 over a counter-clockwise polygon that is star-shaped about
    centre_yz (gear, hexagon and flange outlines), so caps can be fanned from that point."""
    n = len(polygon_yz)
    ring = np.vstack([polygon_yz, centre_yz])
    vertices = np.vstack([np.column_stack([np.full(n + 1, x), ring]) for x in (x0, x1)])
    i = np.arange(n)
    j = (i + 1) % n
    top = n + 1  # index offset of the x1 ring
    faces = np.vstack(
        [
            np.column_stack([i, j, top + j]),
            np.column_stack([i, top + j, top + i]),
            np.column_stack([np.full(n, n), j, i]),
            np.column_stack([np.full(n, top + n), top + i, top + j]),
        ]
    )
    return trimesh.Trimesh(vertices, faces)


def cylinder_x(
    radius: float, x0: float, x1: float, sections: int, centre_yz: tuple[float, float] = (0, 0)
) -> trimesh.Trimesh:
    """Cylinder along x from x0 to x1."""
    return revolve_x([(x0, 0), (x0, radius), (x1, radius), (x1, 0)], sections, centre_yz)


def circle(radius: float, count: int, centre: Sequence[float] = (0, 0)) -> np.ndarray:
    """`count` points counter-clockwise on a circle, the first on +x (or +y of a y-z plane)."""
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return np.column_stack([np.cos(angles), np.sin(angles)]) * radius + np.asarray(centre)


def polar(radius: float, angle: float) -> tuple[float, float]:
    """Cartesian point at `radius` and `angle` (rad)."""
    return radius * np.cos(angle), radius * np.sin(angle)


def box(extents: Point, centre: Point = (0, 0, 0)) -> trimesh.Trimesh:
    """Axis-aligned box of `extents` centred at `centre`."""
    return trimesh.creation.box(
        extents=extents, transform=trimesh.transformations.translation_matrix(centre)
    )


def rod(radius: float, start: Point, end: Point, sections: int) -> trimesh.Trimesh:
    """Cylinder of `radius` from point `start` to point `end` (any direction)."""
    return trimesh.creation.cylinder(radius=radius, sections=sections,
                                     segment=np.array([start, end], dtype=float))


def carve(
    solids: Sequence[trimesh.Trimesh], cuts: Sequence[trimesh.Trimesh] = ()
) -> trimesh.Trimesh:
    """The union of `solids` less the union of `cuts`."""
    body = solids[0] if len(solids) == 1 else trimesh.boolean.union(solids, engine="manifold")
    if not cuts:
        return body
    return trimesh.boolean.difference([body, *cuts], engine="manifold")


def toothed_outline(count: int, root: float, tip: float) -> np.ndarray:
    """Outline of `count` trapezoidal teeth between radii `root` and `tip`, star-shaped about
    the origin: flank up, flat top land, flank down, flat root gap."""
    pitch = 2 * np.pi / count
    shape = [(root, 0.0), (tip, 0.2), (tip, 0.45), (root, 0.65)]
    return np.array([polar(r, (k + f) * pitch) for k in range(count) for r, f in shape])


def annulus_x(r_min: float, r_max: float, x0: float, x1: float, sections: int) -> trimesh.Trimesh:
    """Ring between radii r_min and r_max along x from x0 to x1."""
    segment = [(x0, 0, 0), (x1, 0, 0)]
    return trimesh.creation.annulus(r_min, r_max, sections=sections, segment=segment)


def web_cuts(
    hub_r: float, rim_r: float, width: float, web_ratio: float, hole_count: int
) -> list[trimesh.Trimesh]:
    """Cuts that thin the web of a wheel (gear, pulley) centred on the x axis, `width` wide:
    a recess on each face between hub and rim, and `hole_count` lightening holes through it."""
    depth = (1 - web_ratio) * width / 2
    cuts = [
        annulus_x(hub_r, rim_r, side * (width / 2 - depth), side * (width / 2 + OVERLAP_M), 64)
        for side in (-1, 1)
    ]
    pitch = (hub_r + rim_r) / 2
    # Holes stay clear of hub, rim and each other.
    radius = min(0.35 * (rim_r - hub_r), 0.3 * 2 * np.pi * pitch / max(hole_count, 1))
    for angle in np.arange(hole_count) * 2 * np.pi / max(hole_count, 1):
        x = width / 2 + OVERLAP_M
        cuts.append(cylinder_x(radius, -x, x, 24, polar(pitch, angle)))
    return cuts


def keyed_bore_x(radius: float, x0: float, x1: float) -> list[trimesh.Trimesh]:
    """Cuts of a bore of `radius` along x from x0 to x1 with a keyway on its +z side."""
    key = 0.5 * radius
    keyway = box((x1 - x0, key, key), ((x0 + x1) / 2, 0, radius + key / 2 - 0.25 * key))
    return [cylinder_x(radius, x0, x1, 48), keyway]


def hull(points: ArrayLike) -> trimesh.Trimesh:
    """Convex hull of 3D points, as a closed mesh (ribs, gussets, lever arms)."""
    return trimesh.convex.convex_hull(np.asarray(points, dtype=float))
