"""Which ground-truth points each of many sensor poses sees: a coarse z-buffer per pose.

Model-based planners score hundreds of candidate views by the GT points each would measure. An
acquisition per candidate costs milliseconds even at a coarse resolution (the sensor's per-frame
work is per triangle); here all candidates are rendered together in a few large numpy passes.

Per pose, the object's triangles are z-buffered at the pixel centres of a coarse pinhole grid with
the sensor's opening angles: a pixel keeps the nearest triangle whose projection covers its
centre (the same exact coverage test as the sensor's scan conversion, on projected 2D edges).
A GT point p is visible when it lies in the frustum at a ray distance within [near, far] and is
not hidden: its depth is at most `tolerance` behind the farthest of the four pixel centres
around its projection. On a surface seen without occlusion the depth at p is at most that of
the surrounding pixel centres (the depth is affine across a small planar patch), whereas an
occluder in front covers all four; only a band of about a pixel along occluding edges is
ambiguous. Triangles facing away from the sensor are culled when the mesh is watertight (a
closed surface is always first met from its front). The fixture and the robot are not modelled:
they hide little from the candidate views, and executed views are measured by the real sensor.

Under a `structured_light` sensing model the prediction follows the model's deterministic limits
(docs/sensor.md#sensing; its noise and dropout are drawn per frame and left to the confirming
acquisitions): a point is visible only where the camera ray and the projector ray meet its
surface (the nearest triangle's normal) within their incidence limits from the same side, and
where the projector, at the baseline along the sensor's x axis, sees it by the same depth test on
a grid of the camera's pixel pitch wide enough to hold every point the camera can see.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import trimesh

from vprobot.config import MAX_FOV_DEG
from vprobot.config.sensor import SensorModel
from vprobot.files.progress import stage
from vprobot.geometry.poses import Pose
from vprobot.geometry.raster import covered_pixels, index_range, max3, min3
from vprobot.sensing import IDEAL, SensingModel, StructuredLight

DEFAULT_RESOLUTION = (86, 60)
"""A fifth of the full frame's rays per axis: pixels of about 2.5 mm at the working distance.
Finer grids predict slightly better but barely change the plans once the picks are confirmed by
simulated acquisitions (B_SCP,5: 98.3 % at 108 x 75, 98.4 % at 86 x 60, 98.2 % at 72 x 50 on
the test motors)."""
_CHUNK_PAIRS = 200_000
"""Poses are rendered in chunks of about this many (pose, triangle) pairs: small enough for the
working arrays to stay in cache and be reused between chunks (larger chunks are slower)."""
_MIN_DEPTH = 1e-6


@dataclasses.dataclass(frozen=True)
class _Triangles:
    """(pose, triangle) pairs projected into their pose's image plane.

    Attributes:
        pose: Pose index of each pair.
        u: Image-plane x tangents of the three corners (three arrays).
        v: Image-plane y tangents of the three corners (three arrays).
        inverse_depth: Coefficients (a, b, c) of 1/z = a u + b v + c across the triangle.
        row_lo: First pixel row within the triangle's v-range.
        row_hi: Last pixel row within it.
    """

    pose: np.ndarray
    u: list[np.ndarray]
    v: list[np.ndarray]
    inverse_depth: tuple[np.ndarray, ...]
    row_lo: np.ndarray
    row_hi: np.ndarray


class VisibilityRenderer:
    """Renders a mesh from many sensor poses and tells which points each pose sees.

    Args:
        mesh: The object in its mesh frame (metres).
        sensor: The sensor's geometry (opening angles and range).
        resolution: (width, height) of the coarse grid.
        tolerance_m: How far behind the visible surface a point may lie and still count.
        sensing: The sensing model whose deterministic limits the prediction follows.

    Raises:
        ValueError: If the mesh has no faces, the resolution is not two integers >= 2, or the
            tolerance is not a positive length.
    """

    def __init__(self, mesh: trimesh.Trimesh, sensor: SensorModel,
                 resolution: tuple[int, int] = DEFAULT_RESOLUTION, tolerance_m: float = 0.002,
                 sensing: SensingModel = IDEAL):
        if len(mesh.faces) == 0:
            raise ValueError("mesh has no faces: nothing to render")
        if len(resolution) != 2 or not all(isinstance(n, int | np.integer) and n >= 2
                                           for n in resolution):
            raise ValueError(f"resolution must be two integers >= 2 (width, height), got "
                             f"{resolution!r}")
        if not (np.isfinite(tolerance_m) and tolerance_m > 0):
            raise ValueError(f"tolerance_m must be a positive length, got {tolerance_m!r}")
        self.vertices = np.asarray(mesh.vertices, dtype=float)
        self.faces = np.asarray(mesh.faces, dtype=np.int64)
        self.normals = np.asarray(mesh.face_normals, dtype=float)
        self.cull_back_faces = bool(mesh.is_watertight and mesh.is_winding_consistent)
        self._plane_offsets = np.einsum("fj,fj->f", self.normals, self.vertices[self.faces[:, 0]])
        self.sensor = sensor.at_resolution((int(resolution[0]), int(resolution[1])))
        self.resolution = self.sensor.resolution
        self.tolerance_m = float(tolerance_m)
        self.u, self.v = self.sensor.pixel_tangents
        self._du = self.u[1] - self.u[0]
        self._dv = self.v[1] - self.v[0]
        self.sensing = sensing
        self._mesh = mesh
        self._projector = (self._projector_renderer(mesh, sensing)
                           if isinstance(sensing, StructuredLight) else None)

    def _projector_renderer(self, mesh: trimesh.Trimesh,
                            sensing: StructuredLight) -> VisibilityRenderer:
        """An ideal renderer from the projector's centre, on the camera's pixel pitch, whose
        frustum holds every point the camera can see: at depth z the projector's tangent along x
        is the camera's less baseline / z, and z >= near / |(u, v, 1)| at the frame's corner."""
        half_x, half_y = self.sensor.half_tangents
        near_depth = self.sensor.near_m / np.sqrt(1.0 + half_x**2 + half_y**2)
        wide_x = half_x + sensing.baseline_m / max(near_depth, _MIN_DEPTH)
        width = int(np.ceil(self.resolution[0] * wide_x / half_x))
        # A projector wider than a sensor may be lights no more than that (real ones are
        # narrower): points beyond it count as dark.
        fov_x = min(float(np.degrees(2.0 * np.arctan(wide_x))), MAX_FOV_DEG)
        # Its rays run up to a baseline longer than the camera's; z is the camera's.
        sensor = SensorModel((width, self.resolution[1]), (fov_x, self.sensor.fov_deg[1]), 0.0,
                             self.sensor.far_m + sensing.baseline_m,
                             self.sensor.working_distance_m)
        return VisibilityRenderer(mesh, sensor, sensor.resolution, self.tolerance_m)

    def visible(self, poses: list[Pose], points: np.ndarray) -> np.ndarray:
        """Which points (n, 3) each pose sees; poses and points in the mesh frame.

        Returns:
            Boolean matrix (len(poses), n).
        """
        points = np.asarray(points, dtype=float)
        result = np.zeros((len(poses), len(points)), dtype=bool)
        chunk = max(1, _CHUNK_PAIRS // len(self.faces))
        with stage("visibility", len(poses), "view") as bar:
            for start in range(0, len(poses), chunk):
                batch = poses[start:start + chunk]
                positions = np.array([pose.position for pose in batch])
                rotations = np.array([pose.rotation for pose in batch])
                depth = self.depth_maps(positions, rotations)
                result[start:start + len(batch)] = self._points_visible(depth, positions,
                                                                        rotations, points)
                bar.update(len(batch))
        if isinstance(self.sensing, StructuredLight) and self._projector is not None:
            result &= self._within_limits(poses, points, self.sensing, self._projector)
        return result

    def _within_limits(self, poses: list[Pose], points: np.ndarray, sensing: StructuredLight,
                       projector: VisibilityRenderer) -> np.ndarray:
        """Which points (n, 3) each pose's `projector` lights within both incidence limits."""
        min_camera, min_projector = sensing.min_cos_incidence
        _, _, triangle = self._mesh.nearest.on_surface(points)
        normals = self.normals[triangle]
        positions = np.array([pose.position for pose in poses])
        lights = positions + sensing.baseline_m * np.array([pose.rotation[:, 0]
                                                            for pose in poses])

        def cos_incidence(origins: np.ndarray) -> np.ndarray:
            rays = points[None] - origins[:, None]
            return (np.einsum("kij,ij->ki", rays, normals) / np.linalg.norm(rays, axis=2))

        cos_camera, cos_projector = cos_incidence(positions), cos_incidence(lights)
        within = ((np.abs(cos_camera) >= min_camera) & (np.abs(cos_projector) >= min_projector)
                  & (cos_camera * cos_projector > 0.0))
        return within & projector.visible(
            [Pose(light, pose.rotation) for light, pose in zip(lights, poses, strict=True)],
            points)

    def depth_maps(self, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """Z-depth of the nearest triangle at every pixel centre, per pose (k, h, w); inf where
        no triangle covers the centre."""
        width, height = self.resolution
        triangles = self._triangles(positions, rotations)
        pair, row, column = self._covered_pixels(triangles)
        # 1/z is affine across a triangle's projection, so the nearest hit has the largest 1/z.
        a, b, c = triangles.inverse_depth
        nearness = a[pair] * self.u[column] + b[pair] * self.v[row] + c[pair]
        valid = np.isfinite(nearness) & (nearness > 0)
        index = (triangles.pose[pair] * height + row) * width + column
        buffer = np.zeros(len(positions) * height * width)
        np.maximum.at(buffer, index[valid], nearness[valid])
        with np.errstate(divide="ignore"):
            return (1.0 / buffer).reshape(len(positions), height, width)

    def _triangles(self, positions: np.ndarray, rotations: np.ndarray) -> _Triangles:
        """The (pose, triangle) pairs that can cover a pixel centre."""
        # Vertices in every pose's sensor frame (rotation columns are the sensor axes), as flat
        # coordinate arrays: numpy gathers single values, and works on columns, much faster
        # than on rows of three.
        local = np.matmul(self.vertices[None] - positions[:, None], rotations)
        x, y, z = (np.ascontiguousarray(local[..., axis]).ravel() for axis in range(3))
        pose, face = self._facing_pairs(positions)
        vertex = pose[:, None] * len(self.vertices) + self.faces[face]
        corner_z = [z[vertex[:, k]] for k in range(3)]
        keep = np.flatnonzero((min3(corner_z) > _MIN_DEPTH)
                              & (min3(corner_z) <= self.sensor.far_m))
        pose, vertex = pose[keep], vertex[keep]
        corner_x = [x[vertex[:, k]] for k in range(3)]
        corner_y = [y[vertex[:, k]] for k in range(3)]
        corner_z = [depth[keep] for depth in corner_z]
        cu = [corner_x[k] / corner_z[k] for k in range(3)]
        cv = [corner_y[k] / corner_z[k] for k in range(3)]
        # Triangles between two pixel rows or columns, or outside the frame, cover no centre.
        row_lo, row_hi = index_range(min3(cv), max3(cv), self.v)
        column_lo, column_hi = index_range(min3(cu), max3(cu), self.u)
        keep = np.flatnonzero((row_hi >= row_lo) & (column_hi >= column_lo))
        ax, ay, az = (corner[0][keep] for corner in (corner_x, corner_y, corner_z))
        e1 = [corner[1][keep] - corner[0][keep] for corner in (corner_x, corner_y, corner_z)]
        e2 = [corner[2][keep] - corner[0][keep] for corner in (corner_x, corner_y, corner_z)]
        # The triangle's plane n . p = n . a meets the ray (u, v, 1) at 1/z = n . (u, v, 1) /
        # n . a, with n = e1 x e2.
        normal = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                  e1[0] * e2[1] - e1[1] * e2[0])
        offset = normal[0] * ax + normal[1] * ay + normal[2] * az
        with np.errstate(divide="ignore", invalid="ignore"):
            inverse_depth = tuple(component / offset for component in normal)
        return _Triangles(pose[keep], [c[keep] for c in cu], [c[keep] for c in cv],
                          inverse_depth, row_lo[keep], row_hi[keep])

    def _covered_pixels(self, triangles: _Triangles) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray]:
        """Every (pair, row, column) whose pixel centre lies inside the pair's triangle."""
        cu, cv = triangles.u, triangles.v
        orientation = np.sign((cu[1] - cu[0]) * (cv[2] - cv[0]) - (cv[1] - cv[0]) * (cu[2] - cu[0]))
        # Per edge a -> b, inside is alpha u + beta v + gamma >= 0 (oriented inward).
        edges = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            alpha = -orientation * (cv[b] - cv[a])
            beta = orientation * (cu[b] - cu[a])
            edges.append((alpha, beta, -alpha * cu[a] - beta * cv[a]))
        row_hi = np.where(orientation != 0, triangles.row_hi, triangles.row_lo - 1)
        return covered_pixels(edges, triangles.row_lo, row_hi, self.u, self.v)

    def _facing_pairs(self, positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(pose, face) index pairs of the triangles each pose can see the front of."""
        if not self.cull_back_faces:
            pose, face = np.indices((len(positions), len(self.faces)))
            return pose.ravel(), face.ravel()
        # The sensor lies on the outer side of the triangle's plane.
        pose, face = np.nonzero(positions @ self.normals.T > self._plane_offsets[None])
        return pose, face

    def _points_visible(self, depth: np.ndarray, positions: np.ndarray, rotations: np.ndarray,
                        points: np.ndarray) -> np.ndarray:
        """The depth test of the module docstring for every (pose, point)."""
        _, height, width = depth.shape
        local = np.matmul(points[None] - positions[:, None], rotations)
        candidate = self.sensor.contains(local)
        pose_index, point_index = np.nonzero(candidate)
        x, y, z = (local[pose_index, point_index, axis] for axis in range(3))
        column = (x / z - self.u[0]) / self._du
        row = (y / z - self.v[0]) / self._dv
        # Empty pixels support nothing: they count as infinitely near.
        support = np.where(np.isfinite(depth), depth, -np.inf)
        farthest = np.full(len(pose_index), -np.inf)
        for row_step in (0, 1):
            rows = np.clip(np.floor(row).astype(np.int64) + row_step, 0, height - 1)
            for column_step in (0, 1):
                columns = np.clip(np.floor(column).astype(np.int64) + column_step, 0, width - 1)
                farthest = np.maximum(farthest, support[pose_index, rows, columns])
        seen = z <= farthest + self.tolerance_m
        visible = np.zeros(candidate.shape, dtype=bool)
        visible[pose_index[seen], point_index[seen]] = True
        return visible
