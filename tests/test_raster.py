"""Tests of the shared triangle scan conversion and its two users (sensor, visibility) against a
brute-force per-pixel ray-triangle reference on hand-made triangles."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from vprobot.cell.sensor import _scan_convert
from vprobot.config import SensorConfig
from vprobot.config.sensor import SensorModel
from vprobot.geometry.raster import covered_pixels, index_range, ranks
from vprobot.planners.visibility import VisibilityRenderer

SENSOR = SensorModel.from_config(SensorConfig(resolution=(23, 17), fov_deg=(40.0, 30.0),
                                              near_m=0.1, far_m=2.0))

# Triangles in the sensor frame (+z ahead). Coordinates avoid pixel centres lying on an edge.
TRIANGLES = np.array([
    # Near, counter-clockwise in the image, over the middle of the frame.
    [[-0.031, -0.027, 0.3], [0.043, -0.011, 0.3], [0.007, 0.052, 0.31]],
    # Farther and larger, clockwise, behind the first one: depth order decides the overlap.
    [[-0.101, -0.083, 0.5], [0.002, 0.121, 0.55], [0.133, -0.071, 0.45]],
    # Tilted in depth and running out of the frame on the right.
    [[0.05, 0.01, 0.4], [0.9, -0.13, 1.1], [0.4, 0.22, 0.7]],
    # Degenerate: its corners are collinear.
    [[-0.1, 0.05, 0.4], [-0.05, 0.075, 0.4], [0.0, 0.1, 0.4]],
    # A sliver between two pixel rows, so it covers no pixel centre.
    [[-0.2, 0.0021, 1.0], [0.2, 0.0022, 1.0], [0.0, 0.0029, 1.0]],
])


def _brute_force_depth(triangles: np.ndarray) -> np.ndarray:
    """Z-depth (h, w) of the nearest triangle along every pixel's ray; inf where none."""
    u, v = SENSOR.pixel_tangents
    depth = np.full((len(v), len(u)), np.inf)
    for a, b, c in triangles:
        for row, row_v in enumerate(v):
            for column, column_u in enumerate(u):
                ray = np.array([column_u, row_v, 1.0])
                # ray * t = a + s (b - a) + w (c - a)
                matrix = np.column_stack([ray, a - b, a - c])
                if abs(np.linalg.det(matrix)) < 1e-15:
                    continue
                t, s, w = np.linalg.solve(matrix, a)
                if s >= 0 and w >= 0 and s + w <= 1 and t > 0:
                    depth[row, column] = min(depth[row, column], t)
    return depth


def test_brute_force_reference_sees_each_triangle_in_depth_order() -> None:
    depth = _brute_force_depth(TRIANGLES)
    near_only = _brute_force_depth(TRIANGLES[:1])
    far_only = _brute_force_depth(TRIANGLES[1:2])
    overlap = np.isfinite(near_only) & np.isfinite(far_only)
    # The reference itself is not vacuous: the near triangle hides part of the far one.
    assert overlap.sum() >= 4
    np.testing.assert_allclose(depth[overlap], near_only[overlap])
    assert np.isinf(_brute_force_depth(TRIANGLES[3:])).all()


def test_sensor_scan_conversion_matches_brute_force_rays() -> None:
    u, v = SENSOR.pixel_tangents
    vertices = TRIANGLES.reshape(-1, 3)
    faces = np.arange(len(vertices)).reshape(-1, 3)
    row, column, z_depth, _ = _scan_convert(vertices, faces, u, v, max_depth=10.0)
    depth = np.full((len(v), len(u)), np.inf)
    np.minimum.at(depth, (row, column), z_depth)
    expected = _brute_force_depth(TRIANGLES)
    np.testing.assert_array_equal(np.isfinite(depth), np.isfinite(expected))
    np.testing.assert_allclose(depth[np.isfinite(depth)], expected[np.isfinite(expected)],
                               rtol=1e-12)


def test_visibility_depth_map_matches_brute_force_rays() -> None:
    mesh = trimesh.Trimesh(TRIANGLES.reshape(-1, 3), np.arange(15).reshape(-1, 3),
                           process=False)
    renderer = VisibilityRenderer(mesh, SENSOR, resolution=SENSOR.resolution)
    depth = renderer.depth_maps(np.zeros((1, 3)), np.eye(3)[None])[0]
    expected = _brute_force_depth(TRIANGLES)
    np.testing.assert_array_equal(np.isfinite(depth), np.isfinite(expected))
    np.testing.assert_allclose(depth[np.isfinite(depth)], expected[np.isfinite(expected)],
                               rtol=1e-12)


@pytest.mark.parametrize("clockwise", [False, True])
def test_covered_pixels_are_the_centres_inside_a_2d_triangle(clockwise: bool) -> None:
    u, v = np.linspace(-1.0, 1.0, 9), np.linspace(-1.0, 1.0, 7)
    corners = np.array([[-0.83, -0.71], [0.91, -0.23], [-0.07, 0.88]])
    if clockwise:
        corners = corners[::-1]
    sign = -1.0 if clockwise else 1.0
    edges = []
    for start, end in ((0, 1), (1, 2), (2, 0)):
        (ua, va), (ub, vb) = corners[start], corners[end]
        alpha, beta = -sign * (vb - va), sign * (ub - ua)
        edges.append((np.array([alpha]), np.array([beta]), np.array([-alpha * ua - beta * va])))
    triangle, row, column = covered_pixels(edges, np.array([0]), np.array([len(v) - 1]), u, v)
    found = {(int(r), int(c)) for r, c in zip(row, column, strict=True)}
    expected = set()
    for r, row_v in enumerate(v):
        for c, column_u in enumerate(u):
            signs = []
            for k in range(3):
                (ua, va), (ub, vb) = corners[k], corners[(k + 1) % 3]
                signs.append(sign * ((ub - ua) * (row_v - va) - (vb - va) * (column_u - ua)))
            if min(signs) >= 0:
                expected.add((r, c))
    assert len(expected) >= 10
    assert (triangle == 0).all()
    assert found == expected


def test_index_range_and_ranks_by_hand() -> None:
    centres = np.array([0.0, 0.5, 1.0, 1.5])
    first, last = index_range(np.array([0.2, -np.inf, 0.6, 2.0]),
                              np.array([1.1, np.inf, 0.9, 3.0]), centres)
    np.testing.assert_array_equal(first, [1, 0, 2, 4])
    np.testing.assert_array_equal(last, [2, 3, 1, 3])
    np.testing.assert_array_equal(ranks(np.array([2, 0, 3])), [0, 1, 0, 1, 2])
