"""The 3D sensor: a pinhole grid of rays cast from the `sensor` site into the cell
(docs/sensor.md).

The grid, its opening angles and range are a `SensorModel` (`vprobot.config.sensor`, which also
documents the sensor frame). Only a ray's first hit in the whole cell counts: it is kept when it
lies on the object and its distance is within [near, far]; a ray that first meets the robot, the
fixture or the floor is occluded. Rays start at the optical centre, on the front of the sensor
housing, so the sensor body itself is excluded.

How a frame is computed in milliseconds: MuJoCo's ray-mesh test walks the whole mesh BVH without
pruning by the nearest hit found so far, which costs several microseconds for every ray that hits
a motor (about 0.3 s for a frame). Because the rays form a pinhole grid, mesh hits are instead
found by exact scan conversion of the triangles: per pixel row, a triangle covers the pixel
centres that lie inside its three edge planes through the optical centre, and every pixel keeps
its nearest triangle (a z-buffer). That is the ray-triangle intersection `mj_multiRay` computes,
on the same float32 vertices, and the tests check that both give the same points. The object is
scan converted first; the robot's meshes then only within the window of its in-range hits. The
primitive geoms (fixture plate, pedestal, floor, robot stand) are left to `mujoco.mj_multiRay`,
for the few rays whose segment to the object crosses their bounding boxes, on worker threads
(MuJoCo releases the GIL; each thread has its own MjData).

The sensing model (`vprobot.sensing`) then decides which hits become points, reading them and
the geometry it needs (rays, normals, what a light source beside the camera reaches) through
`CameraHits`: all of them, exactly (`ideal`), or under `structured_light` those within the
incidence limits that a second visibility pass from the projector finds lit, with noise and
dropout (docs/sensor.md#sensing).
`DepthSensor.losses_at` tells which hits a frame lost and why (docs/sensor.md#lost-points).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor

import mujoco
import numpy as np

from vprobot.cell.scene import Cell
from vprobot.config.sensor import SensorModel
from vprobot.geometry.poses import Pose
from vprobot.geometry.raster import covered_pixels, index_range, max3, min3
from vprobot.sensing import SensingModel, frame_generator

TRAINING_RESOLUTION = (320, 224)
"""A coarser frame for training (0.56 of the rays, same opening angles and aspect). Its
single-view coverage is below the full frame's by about 0.7 percentage points on average; a
quarter of the rays (215 x 150) would lose about 2 points (`vprobot benchmark sensor`)."""

# Pixel spans are widened by this much (in tan units, pixels are ~1e-3 wide) so that a pixel
# centre lying exactly on an edge shared by two triangles is not lost to rounding.
_SPAN_SLACK = 1e-12
# Vertices closer than this to the image plane through the optical centre are not projected.
_MIN_DEPTH = 1e-9
# The projector's depth map has this many times the camera's pixel pitch along each axis: a
# quarter of the pixels to scan convert (a projector has fewer pixels than the camera, and shadow
# edges fall within one of its pixels).
_PROJECTOR_PITCH = 2
# A surface nearer to the projector than a point by more than this many projector pixel
# footprints (at the point's depth) shadows it; less is the point's own surface or a
# neighbouring facet of it.
_SHADOW_TOLERANCE_PIXELS = 1.0
# Fewer MuJoCo rays than this per thread are cast on one thread.
_MIN_RAYS_PER_THREAD = 2000


@dataclasses.dataclass(frozen=True)
class Acquisition:
    """One frame of the sensor: the object points it measured.

    Attributes:
        points_world: Measured points (n, 3) in the world frame.
        points_object: The same points relative to the object centre, axes parallel to the world.
        pixels: Row-major pixel index (n,) of each point.
        blocked_pixels: Pixels whose ray met the object within range behind the robot or a
            part of the cell (the sensor sees that occluder, which a cell knows, not the object).
        sensor_pose: Sensor frame in the world (+z viewing direction).
        object_pose: Object (mesh) frame in the world when the frame was taken.
        rays_cast: Rays of the frame (width * height).
    """

    points_world: np.ndarray
    points_object: np.ndarray
    pixels: np.ndarray
    blocked_pixels: np.ndarray
    sensor_pose: Pose
    object_pose: Pose
    rays_cast: int

    @property
    def points_mesh(self) -> np.ndarray:
        """The points in the object's mesh frame, where ground truth and coverage live."""
        return self.points_object @ self.object_pose.rotation

    def __len__(self) -> int:
        return len(self.points_world)


LOSS_CAUSES = ("shadowed", "grazing", "dropped out")
"""Why a frame lost a point the ideal sensor measures there (`DepthSensor.losses_at`), in the
order they are told apart: the projector leaves it dark (its shadow, or a surface it lights from
behind), the camera or the projector ray meets it beyond an incidence limit, it drops out."""


@dataclasses.dataclass(frozen=True)
class FrameLosses:
    """The points of a frame the ideal sensor measures, and which of them the sensing model lost.

    Attributes:
        ideal: The frame under the ideal model: every hit, exactly where it lies.
        cause: Per point of `ideal`, the index in `LOSS_CAUSES` of why it was lost; -1 where it
            was measured.
    """

    ideal: Acquisition
    cause: np.ndarray

    def lost(self, cause: str) -> np.ndarray:
        """The points of `ideal` lost to `cause` (one of `LOSS_CAUSES`), in the world (n, 3)."""
        return self.ideal.points_world[self.cause == LOSS_CAUSES.index(cause)]

    def counts(self) -> dict[str, int]:
        """How many points were measured and how many lost to each cause."""
        counts = np.bincount(self.cause + 1, minlength=len(LOSS_CAUSES) + 1)
        return dict(zip(("measured", *LOSS_CAUSES), map(int, counts), strict=True))


@dataclasses.dataclass(frozen=True)
class _MeshGeom:
    """A mesh geom's triangles as MuJoCo stores them: float32 vertices in the geom frame."""

    geom_id: int
    vertices: np.ndarray
    faces: np.ndarray
    radius: float

    @functools.cached_property
    def normals(self) -> np.ndarray:
        """Unit normals (m, 3) of the triangles in the geom frame (zero for degenerate ones)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        normals = np.cross(b - a, c - a)
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)

    @classmethod
    def of(cls, model: mujoco.MjModel, geom: int) -> _MeshGeom:
        mesh = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        first, nface = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        vertices = model.mesh_vert[start:start + count].astype(float)
        return cls(int(geom), vertices, model.mesh_face[first:first + nface].astype(np.int64),
                   float(np.linalg.norm(vertices, axis=1).max()))

    def in_frame(self, data: mujoco.MjData, frame: Pose) -> np.ndarray:
        """The vertices expressed in `frame` (a pose in the world)."""
        rotation = frame.rotation.T @ data.geom_xmat[self.geom_id].reshape(3, 3)
        offset = frame.rotation.T @ (data.geom_xpos[self.geom_id] - frame.position)
        return self.vertices @ rotation.T + offset


def _ray_visible(model: mujoco.MjModel, geom: int) -> bool:
    """Whether MuJoCo's ray casts consider the geom at all (they skip transparent ones)."""
    material = model.geom_matid[geom]
    alpha = model.mat_rgba[material, 3] if material >= 0 else model.geom_rgba[geom, 3]
    return bool(alpha != 0)


class DepthSensor:
    """Ray-cast 3D sensor of a cell: point clouds of the object from the `sensor` site.

    Not thread-safe: one sensor serves one caller at a time (it owns buffers and MjData copies).

    Args:
        cell: The compiled cell. Its object geoms must be meshes, in geom groups that hold no
            primitive geoms.
        sensor: The sensor's geometry; the model of the cell's sensor config when omitted.
        resolution: (width, height) in rays, e.g. a coarser frame for training; the sensor's
            own when omitted. The opening angles stay the same.
        workers: Threads for the MuJoCo ray casts.
        groups: Geom groups the rays see, as MuJoCo's geomgroup; all when omitted. Leaving out
            the robot's group (2) measures as if the robot were not there.
        sensing: How hits become points (a `vprobot.sensing.SensingModel`); the cell's sensor
            config's model when omitted.

    Raises:
        ValueError: If the resolution or worker count is invalid, an object geom is not a mesh,
            a primitive geom shares the object's geom group, or `groups` leaves out the object.
        TypeError: If `sensing` is not a sensing model.
    """

    def __init__(self, cell: Cell, sensor: SensorModel | None = None,
                 resolution: tuple[int, int] | None = None, workers: int = 2,
                 groups: Sequence[int] | None = None, sensing: SensingModel | None = None):
        sensor = sensor if sensor is not None else SensorModel.from_config(cell.config.sensor)
        self.sensor = sensor.at_resolution(resolution) if resolution is not None else sensor
        self.resolution = self.sensor.resolution
        if not (isinstance(workers, int) and workers >= 1):
            raise ValueError(f"workers must be a positive integer, got {workers!r}")
        sensing = sensing if sensing is not None else cell.config.sensor.sensing_model
        if not isinstance(sensing, SensingModel):
            raise TypeError(f"sensing must be a vprobot.sensing.SensingModel, got {sensing!r}")
        self.sensing = sensing
        self.model = cell.model
        self._site_id = cell.sensor_site_id
        self._sensor_body_id = cell.sensor_body_id
        self._object_body_id = cell.object_body_id
        self._classify_geoms(np.asarray(cell.object_geom_ids, dtype=int), groups)
        self._u, self._v = self.sensor.pixel_tangents
        self.directions = self.sensor.ray_directions
        # Distance along a ray per unit of z-depth.
        self._ray_scale = 1.0 / self.directions[:, 2]
        self._object_depth = np.empty(self.rays_per_frame)
        self._occluder_depth = np.empty(self.rays_per_frame)
        self._geomid = np.empty(self.rays_per_frame, dtype=np.int32)
        # The object triangle each pixel keeps (numbered as `_normals` numbers them), for a
        # model that reads the normals.
        self._face = (np.empty(self.rays_per_frame, dtype=np.int32)
                      if sensing.uses_normals else None)
        self._distance = np.empty(self.rays_per_frame)
        self._worker_data = [mujoco.MjData(self.model) for _ in range(workers)]
        self._pool = ThreadPoolExecutor(workers) if workers > 1 else None
        self._cell = cell
        self._placed: np.ndarray | None = None

    def _classify_geoms(self, object_geom_ids: np.ndarray,
                        seen_groups: Sequence[int] | None) -> None:
        """Split the cell's geoms into scan-converted meshes and geoms left to MuJoCo.

        Meshes are scan converted where their whole geom group is meshes; every group that holds
        a primitive (plane, box, cylinder, ...) is cast with `mj_multiRay` instead, which is fast
        for primitives. The sensor body is left out: the rays start on its housing.
        """
        model = self.model
        groups = np.clip(model.geom_group, 0, mujoco.mjNGROUP - 1)
        seen = {int(group) for group in (range(mujoco.mjNGROUP) if seen_groups is None
                                         else seen_groups)}
        if not seen <= set(range(mujoco.mjNGROUP)):
            raise ValueError(f"groups must lie in 0..{mujoco.mjNGROUP - 1}, got {sorted(seen)}")
        considered = [g for g in range(model.ngeom)
                      if model.geom_bodyid[g] != self._sensor_body_id and _ray_visible(model, g)
                      and groups[g] in seen]
        is_mesh = model.geom_type == mujoco.mjtGeom.mjGEOM_MESH
        primitive_groups = {int(groups[g]) for g in considered if not is_mesh[g]}
        for geom in object_geom_ids:
            if not is_mesh[geom]:
                raise ValueError(f"object geom {geom} must be a mesh, got geom type "
                                 f"{mujoco.mjtGeom(model.geom_type[geom]).name}")
            if groups[geom] not in seen:
                raise ValueError(f"groups {sorted(seen)} leave out the object's geom "
                                 f"group {groups[geom]}")
            if groups[geom] in primitive_groups:
                raise ValueError(f"object geom {geom} is in geom group {groups[geom]}, which "
                                 f"also holds primitive geoms; the object needs a group of "
                                 f"meshes only")
        self._object_meshes = [_MeshGeom.of(model, g) for g in object_geom_ids]
        self._occluder_meshes = [
            _MeshGeom.of(model, g) for g in considered
            if groups[g] not in primitive_groups and g not in set(object_geom_ids.tolist())
        ]
        self._ray_geoms = np.array([g for g in considered if groups[g] in primitive_groups],
                                   dtype=int)
        self._geomgroup = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
        self._geomgroup[sorted(primitive_groups)] = 1

    @property
    def rays_per_frame(self) -> int:
        return self.sensor.rays_per_frame

    def acquire_at(self, pose: Pose, object_rotation: np.ndarray,
                   joints: np.ndarray | None = None,
                   rng: np.random.Generator | None = None) -> Acquisition:
        """Measure from `pose` with the object turned by `object_rotation` and the robot at
        `joints` (`home` when omitted), on the sensor's own MjData.

        The state is passed whole on every call, so that no other user of the cell (kinematics,
        collision checks, a renderer) can change what the sensor sees. `rng` as in
        `acquire_from_pose`.
        """
        return self.acquire_from_pose(self._state(object_rotation, joints), pose, rng)

    def losses_at(self, pose: Pose, object_rotation: np.ndarray,
                  joints: np.ndarray | None = None) -> FrameLosses:
        """What the frame `acquire_at` takes with these arguments lost to the sensing model,
        and why (`losses_from_pose`)."""
        return self.losses_from_pose(self._state(object_rotation, joints), pose)

    def _state(self, object_rotation: np.ndarray, joints: np.ndarray | None) -> mujoco.MjData:
        """The sensor's own MjData with the object turned by `object_rotation` and the robot at
        `joints` (`home` when omitted)."""
        cell, data = self._cell, self._own_data
        joints = cell.joints.start if joints is None else joints
        # Placing the object costs more than the kinematics: redo it only when the pose changes.
        if self._placed is None or not np.array_equal(self._placed, object_rotation):
            data.qpos[:] = joints
            cell.place_object(data, object_rotation)
            self._placed = np.array(object_rotation, dtype=float)
        elif not np.array_equal(data.qpos, joints):
            data.qpos[:] = joints
            mujoco.mj_kinematics(self.model, data)
        return data

    @functools.cached_property
    def _own_data(self) -> mujoco.MjData:
        return self._cell.make_data()

    def acquire(self, data: mujoco.MjData, rng: np.random.Generator | None = None
                ) -> Acquisition:
        """Measure from the `sensor` site of `data` (kinematics already computed); `rng` as in
        `acquire_from_pose`."""
        site = self._site_id
        pose = Pose(data.site_xpos[site].copy(), data.site_xmat[site].reshape(3, 3).copy())
        return self.acquire_from_pose(data, pose, rng)

    def acquire_from_pose(self, data: mujoco.MjData, pose: Pose,
                          rng: np.random.Generator | None = None) -> Acquisition:
        """Measure from an arbitrary sensor pose in the cell state `data`.

        The robot stays where `data` has it (it can occlude); the rays start at `pose`.

        Args:
            data: The cell state.
            pose: The sensor frame in the world.
            rng: The sensing model's random draws (structured light's noise and dropout); when
                omitted, a generator seeded from the sensor and object poses
                (`vprobot.sensing.frame_generator`), so that the same frame always gets the same
                noise. The ideal model draws nothing.
        """
        frame = self._camera_hits(data, pose)
        if len(frame):
            pixels, points = self.sensing.measure(_CameraHits(self, data, pose, frame, rng))
            frame = dataclasses.replace(frame, points_world=points, pixels=pixels,
                                        points_object=points - frame.object_pose.position)
        return frame

    def losses_from_pose(self, data: mujoco.MjData, pose: Pose) -> FrameLosses:
        """What the frame `acquire_from_pose(data, pose)` takes lost to the sensing model, and
        why: the camera's hits (the ideal frame) measured under the model's reductions in turn
        (`SensingModel.loss_stages`; for `structured_light` the projector alone, its limits and
        the whole model), each keeping a subset of the one before's points; a point is lost to
        the first that drops it (`LOSS_CAUSES`). Nothing is lost under a model without stages,
        such as the ideal one.
        """
        ideal = self._camera_hits(data, pose)
        cause = np.full(len(ideal), -1)
        stages = self.sensing.loss_stages()
        if stages and len(ideal):
            kept = [stage.measure(_CameraHits(self, data, pose, ideal, None))[0]
                    for stage in stages]
            # The last step first: each earlier one overwrites, so the first to drop a point
            # names its cause.
            for index, pixels in reversed(list(enumerate(kept))):
                cause[~np.isin(ideal.pixels, pixels, assume_unique=True)] = index
            cause[np.isin(ideal.pixels, kept[-1], assume_unique=True)] = -1
        return FrameLosses(ideal, cause)

    @staticmethod
    def _frame_generator(frame: Acquisition) -> np.random.Generator:
        """The noise and dropout draws of `frame`, when the caller gives none."""
        return frame_generator(frame.sensor_pose.position, frame.sensor_pose.rotation,
                               frame.object_pose.position, frame.object_pose.rotation)

    def _camera_hits(self, data: mujoco.MjData, pose: Pose) -> Acquisition:
        """The frame before the sensing model: every object hit within range that nothing in
        the cell hides from the camera, exactly where its ray meets the surface."""
        body = self._object_body_id
        object_pose = Pose(data.xpos[body].copy(), data.xmat[body].reshape(3, 3).copy())
        pixels = self._first_hits(self._object_meshes, data, pose, self._object_depth,
                                  self.sensor.far_m, faces=self._face)
        distance = self._object_depth[pixels] * self._ray_scale[pixels]
        in_range = self.sensor.in_range(distance)
        pixels, distance = pixels[in_range], distance[in_range]
        in_range_pixels = pixels
        if len(pixels):
            pixels, distance = self._unoccluded_by_meshes(data, pose, pixels, distance)
        directions = self.directions[pixels] @ pose.rotation.T
        points = pose.position + directions * distance[:, None]
        if len(pixels):
            visible = ~self._occluded_by_ray_geoms(data, pose.position, directions, distance,
                                                   points)
            pixels, points = pixels[visible], points[visible]
        # Pixels the camera sees the object in are not blocked, whether or not the projector
        # lights them: the cell does not see its own occluder there.
        blocked_pixels = np.setdiff1d(in_range_pixels, pixels, assume_unique=True)
        return Acquisition(points_world=points, points_object=points - object_pose.position,
                           pixels=pixels, blocked_pixels=blocked_pixels,
                           sensor_pose=pose, object_pose=object_pose,
                           rays_cast=self.rays_per_frame)

    def _normals(self, data: mujoco.MjData, pose: Pose) -> np.ndarray:
        """Unit normals (m, 3) of every object triangle in the sensor frame, numbered as the
        pixels' triangles are."""
        return np.concatenate([
            mesh.normals @ (pose.rotation.T @ data.geom_xmat[mesh.geom_id].reshape(3, 3)).T
            for mesh in self._object_meshes])

    def _lit(self, data: mujoco.MjData, pose: Pose, baseline: float, light: np.ndarray,
             light_distance: np.ndarray, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """The indices of the points the projector reaches unoccluded.

        A depth map from the projector's centre, scan converted like the camera's frame on a
        grid of `_PROJECTOR_PITCH` times the camera's pixel pitch covering the points, holds the
        nearest object or robot surface per pixel; a point is lit when that surface is not
        nearer than the point's own surface at the same pixel (its triangle's plane, extended to
        the pixel's ray) by more than a projector pixel's footprint. The fixture and the other
        primitives are cast with MuJoCo, ray by ray.

        Args:
            data: The cell state.
            pose: The sensor (camera) frame in the world; the projector shares its axes.
            baseline: The projector's distance from the camera along the sensor's +x axis.
            light: The points relative to the projector's centre, in the sensor frame.
            light_distance: Their distances from the projector's centre.
            points: The same points in the world.
            normals: Their surfaces' unit normals in the sensor frame.
        """
        origin = pose.position + baseline * pose.rotation[:, 0]
        projector = Pose(origin, pose.rotation)
        u, v = self._u, self._v
        step_u = _PROJECTOR_PITCH * (u[1] - u[0] if len(u) > 1 else 1.0)
        step_v = _PROJECTOR_PITCH * (v[1] - v[0] if len(v) > 1 else 1.0)
        column = np.rint((light[:, 0] / light[:, 2] - u[0]) / step_u).astype(np.int64)
        row = np.rint((light[:, 1] / light[:, 2] - v[0]) / step_v).astype(np.int64)
        first_column, first_row = int(column.min()), int(row.min())
        grid_u = u[0] + step_u * np.arange(first_column, int(column.max()) + 1)
        grid_v = v[0] + step_v * np.arange(first_row, int(row.max()) + 1)
        column -= first_column
        row -= first_row
        depth = np.full(len(grid_u) * len(grid_v), np.inf)
        max_distance = float(light_distance.max())
        cone = float(np.arctan(np.hypot(np.abs(grid_u).max(), np.abs(grid_v).max())))
        for mesh in self._object_meshes + self._occluder_meshes:
            if self._in_view(mesh, data, projector, max_distance, cone):
                hit_row, hit_column, z_depth, _ = _scan_convert(
                    mesh.in_frame(data, projector), mesh.faces, grid_u, grid_v, max_distance)
                np.minimum.at(depth, hit_row * len(grid_u) + hit_column, z_depth)
        nearest = depth[row * len(grid_u) + column]
        # The point's own plane where the pixel's ray (u, v, 1) meets it (the point's depth if
        # that ray runs along the plane).
        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.einsum("ij,ij->i", normals, light) / (
                normals[:, 0] * grid_u[column] + normals[:, 1] * grid_v[row] + normals[:, 2])
        own = np.where(np.isfinite(own) & (own > 0.0), own, light[:, 2])
        tolerance = _SHADOW_TOLERANCE_PIXELS * max(step_u, step_v) * light[:, 2]
        lit = np.flatnonzero(nearest >= own - tolerance)
        if len(lit):
            points = np.take(points, lit, axis=0)
            directions = (points - origin) / light_distance[lit, None]
            lit = lit[~self._occluded_by_ray_geoms(data, origin, directions,
                                                   light_distance[lit], points)]
        return lit

    def _in_view(self, mesh: _MeshGeom, data: mujoco.MjData, pose: Pose,
                 max_distance: float, cone_angle: float | None = None) -> bool:
        """Whether the mesh's bounding sphere meets the frustum's cone (or a cone of half-angle
        `cone_angle` around +z) within `max_distance`."""
        offset = data.geom_xpos[mesh.geom_id] - pose.position
        distance = float(np.linalg.norm(offset))
        if distance - mesh.radius > max_distance:
            return False
        if distance <= mesh.radius:
            return True
        off_axis = np.arccos(np.clip(offset @ pose.rotation[:, 2] / distance, -1.0, 1.0))
        cone_angle = cone_angle if cone_angle is not None else self.sensor.cone_angle_rad
        return bool(off_axis - np.arcsin(mesh.radius / distance) <= cone_angle)

    def _first_hits(self, meshes: list[_MeshGeom], data: mujoco.MjData, pose: Pose,
                    depth: np.ndarray, max_distance: float,
                    window: tuple[slice, slice] | None = None,
                    faces: np.ndarray | None = None) -> np.ndarray:
        """Z-buffer the meshes into `depth`; return the pixels that have a hit.

        Only hits that can lie within `max_distance` matter; `window` (rows, columns) limits
        the scan to part of the frame. `faces`, if given, receives the triangle each pixel keeps
        (numbered across the meshes in order).
        """
        depth.fill(np.inf)
        rows, columns = window if window is not None else (slice(None), slice(None))
        u, v = self._u[columns], self._v[rows]
        row_offset, column_offset = rows.start or 0, columns.start or 0
        face_offset = 0
        for mesh in meshes:
            if self._in_view(mesh, data, pose, max_distance):
                row, column, z_depth, face = _scan_convert(
                    mesh.in_frame(data, pose), mesh.faces, u, v, max_distance, faces is not None)
                pixels = (row + row_offset) * self.resolution[0] + column + column_offset
                np.minimum.at(depth, pixels, z_depth)
                if faces is not None and face is not None:
                    # A later mesh that comes nearer overwrites the pixel again.
                    nearest = z_depth == depth[pixels]
                    faces[pixels[nearest]] = face[nearest] + face_offset
            face_offset += len(mesh.faces)
        return np.flatnonzero(np.isfinite(depth))

    def _unoccluded_by_meshes(self, data: mujoco.MjData, pose: Pose, pixels: np.ndarray,
                              distance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Drop the object hits that a scan-converted mesh (the robot) hides."""
        width = self.resolution[0]
        rows = pixels // width
        columns = pixels - rows * width
        window = (slice(int(rows[0]), int(rows[-1]) + 1),
                  slice(int(columns.min()), int(columns.max()) + 1))
        self._first_hits(self._occluder_meshes, data, pose, self._occluder_depth,
                         float(distance.max()), window)
        visible = self._occluder_depth[pixels] >= self._object_depth[pixels]
        return pixels[visible], distance[visible]

    def _occluded_by_ray_geoms(self, data: mujoco.MjData, origin: np.ndarray,
                               directions: np.ndarray, distance: np.ndarray,
                               points: np.ndarray) -> np.ndarray:
        """Whether a primitive geom (fixture, floor, ...) hides each object hit.

        Bounding boxes pick the few rays worth a MuJoCo cast.
        """
        may_meet = np.zeros(len(points), dtype=bool)
        # Column by column: a reduction along axis 0 of an (n, 3) array costs several times more.
        segments_lo = np.minimum([points[:, axis].min() for axis in range(3)], origin)
        segments_hi = np.maximum([points[:, axis].max() for axis in range(3)], origin)
        for geom in self._ray_geoms:
            rotation = data.geom_xmat[geom].reshape(3, 3)
            if self.model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_PLANE:
                # MuJoCo's planes are one-sided: only rays from the front that pass through.
                normal, offset = rotation[:, 2], data.geom_xpos[geom] @ rotation[:, 2]
                if origin @ normal > offset:
                    may_meet |= points @ normal < offset
                continue
            local_center, half = self.model.geom_aabb[geom, :3], self.model.geom_aabb[geom, 3:]
            center = data.geom_xpos[geom] + rotation @ local_center
            reach = np.abs(rotation) @ half
            if np.any(center - reach > segments_hi) or np.any(center + reach < segments_lo):
                continue
            may_meet |= _segments_meet_box(rotation.T @ (origin - center), directions @ rotation,
                                           distance, half)
        candidates = np.flatnonzero(may_meet)
        occluded = np.zeros(len(points), dtype=bool)
        if len(candidates):
            occluded[candidates] = self._cast(data, origin, directions[candidates],
                                              distance[candidates])
        return occluded

    def _cast(self, data: mujoco.MjData, origin: np.ndarray, directions: np.ndarray,
              distance: np.ndarray) -> np.ndarray:
        """`mj_multiRay` against the primitive groups: whether each ray hits before `distance`."""
        count = len(directions)
        # Handing out work pays off only for many rays; most frames have a few near the fixture.
        workers = min(len(self._worker_data), max(1, count // _MIN_RAYS_PER_THREAD))
        bounds = np.linspace(0, count, workers + 1).astype(int)
        directions = np.ascontiguousarray(directions)
        cutoff = float(distance.max())

        def cast(worker: int) -> None:
            start, stop = bounds[worker], bounds[worker + 1]
            worker_data = self._worker_data[worker]
            # mj_multiRay reads only these frames (the bodies' inertial frames bound their geoms);
            # copying them is cheaper than kinematics.
            worker_data.geom_xpos[:] = data.geom_xpos
            worker_data.geom_xmat[:] = data.geom_xmat
            worker_data.xipos[:] = data.xipos
            worker_data.ximat[:] = data.ximat
            mujoco.mj_multiRay(self.model, worker_data, origin, directions[start:stop].ravel(),
                               self._geomgroup, 1, self._sensor_body_id,
                               self._geomid[start:stop], self._distance[start:stop], None,
                               stop - start, cutoff)

        if workers == 1 or self._pool is None:
            cast(0)
        else:
            list(self._pool.map(cast, range(workers)))
        hit = self._distance[:count]
        return (self._geomid[:count] >= 0) & (hit >= 0) & (hit < distance)


@dataclasses.dataclass
class _CameraHits:
    """A frame's camera hits as its sensing model reads them (`vprobot.sensing.CameraHits`):
    the frame before the model, and the sensor's geometry of it.

    Attributes:
        sensor: The sensor that took the frame, its buffers still holding the frame's hits.
        data: The cell state of the frame.
        pose: The sensor frame in the world.
        frame: The camera's hits (`DepthSensor._camera_hits`).
        given_rng: The caller's random draws, or None for the frame's own (`rng`).
    """

    sensor: DepthSensor
    data: mujoco.MjData
    pose: Pose
    frame: Acquisition
    given_rng: np.random.Generator | None

    @property
    def pixels(self) -> np.ndarray:
        return self.frame.pixels

    @property
    def points(self) -> np.ndarray:
        return self.frame.points_world

    @property
    def sensor_position(self) -> np.ndarray:
        return self.pose.position

    @functools.cached_property
    def rng(self) -> np.random.Generator:
        # Made only when the model draws: the ideal model never does.
        if self.given_rng is not None:
            return self.given_rng
        return DepthSensor._frame_generator(self.frame)

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        return np.take(self.sensor.directions, pixels, axis=0)

    def distances(self, pixels: np.ndarray) -> np.ndarray:
        return self.sensor._object_depth[pixels] * self.sensor._ray_scale[pixels]

    def normals(self, pixels: np.ndarray) -> np.ndarray:
        faces = self.sensor._face
        if faces is None:
            raise TypeError(f"sensing model {self.sensor.sensing.name!r} reads normals: set its "
                            f"uses_normals")
        return np.take(self.sensor._normals(self.data, self.pose), faces[pixels], axis=0)

    def lit(self, baseline_m: float, light: np.ndarray, light_distance: np.ndarray,
            points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        return self.sensor._lit(self.data, self.pose, baseline_m, light, light_distance, points,
                                normals)


def _scan_convert(vertices: np.ndarray, faces: np.ndarray, u: np.ndarray, v: np.ndarray,
                  max_depth: float, with_faces: bool = False
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Exact ray-triangle hits of a pinhole grid of rays through the origin.

    Args:
        vertices: Triangle vertices (n, 3) in the sensor frame.
        faces: Vertex indices (m, 3).
        u: Tangents of the pixel columns (image x / z), evenly spaced.
        v: Tangents of the pixel rows (image y / z), evenly spaced.
        max_depth: Triangles entirely deeper (z) than this are skipped.
        with_faces: Also return the triangle of each hit.

    Returns:
        Row, column, z-depth and triangle (index into `faces`) of every (triangle, pixel) hit;
        a pixel can repeat. The triangles are None unless asked for, which keeps the ideal
        sensor's frame as fast as before.
    """
    depth = vertices[:, 2]
    safe_depth = np.where(depth > _MIN_DEPTH, depth, 1.0)
    vertex_u, vertex_v = vertices[:, 0] / safe_depth, vertices[:, 1] / safe_depth
    corner_depth = [depth[faces[:, k]] for k in range(3)]
    corner_u = [vertex_u[faces[:, k]] for k in range(3)]
    corner_v = [vertex_v[faces[:, k]] for k in range(3)]
    nearest, farthest = min3(corner_depth), max3(corner_depth)
    # A triangle crossing the image plane projects without bounds: give it the whole frame.
    in_front = nearest > _MIN_DEPTH
    u_min = np.where(in_front, min3(corner_u), -np.inf)
    u_max = np.where(in_front, max3(corner_u), np.inf)
    v_min = np.where(in_front, min3(corner_v), -np.inf)
    v_max = np.where(in_front, max3(corner_v), np.inf)
    keep = np.flatnonzero((farthest > 0) & (nearest <= max_depth) & (u_max >= u[0])
                          & (u_min <= u[-1]) & (v_max >= v[0]) & (v_min <= v[-1]))
    faces = faces[keep]
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    # Edge planes through the optical centre: the ray along r = (u, v, 1) meets the triangle iff
    # r . (b x c), r . (c x a) and r . (a x b) all have the sign of the triple product
    # a . (b x c) (or are zero); then r is a non-negative combination of a, b and c.
    edges = [np.cross(b, c), np.cross(c, a), np.cross(a, b)]
    triple = np.einsum("ij,ij->i", a, edges[0])
    orientation = np.sign(triple)[:, None]
    edges = [np.ascontiguousarray((edge * orientation).T) for edge in edges]
    normal = np.ascontiguousarray(np.cross(b - a, c - a).T)
    plane = np.einsum("ji,ij->i", normal, a)

    row_lo, row_hi = index_range(v_min[keep], v_max[keep], v, _SPAN_SLACK)
    # Degenerate triangles (zero triple product) cover nothing.
    row_hi = np.where(triple != 0, row_hi, row_lo - 1)
    face, row, column = covered_pixels([(edge[0], edge[1], edge[2]) for edge in edges], row_lo,
                                       row_hi, u, v, _SPAN_SLACK)
    # z-depth where the pixel's ray meets the triangle's plane.
    with np.errstate(divide="ignore", invalid="ignore"):
        row_term = normal[1][face] * v[row] + normal[2][face]
        z_depth = plane[face] / (normal[0][face] * u[column] + row_term)
    valid = np.isfinite(z_depth) & (z_depth > 0)
    return (row[valid], column[valid], z_depth[valid],
            keep[face[valid]] if with_faces else None)


def _segments_meet_box(origin: np.ndarray, directions: np.ndarray, length: np.ndarray,
                       half: np.ndarray) -> np.ndarray:
    """Slab test: whether origin + t * direction, 0 <= t <= length, meets the box |x| <= half."""
    # A zero direction component gives infinite slab bounds: (-inf, inf) when the origin lies
    # between the two planes, empty otherwise; fmin / fmax are the cheap reductions here. (An
    # origin exactly on such a plane gives a nan bound, which fmin / fmax skip: that ray misses.)
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = 1.0 / directions
        near = (-half - origin) * inverse
        far = (half - origin) * inverse
    entry = np.fmin(near, far)
    leave = np.fmax(near, far)
    t_in = np.fmax(np.fmax(entry[:, 0], entry[:, 1]), np.fmax(entry[:, 2], 0.0))
    t_out = np.fmin(np.fmin(leave[:, 0], leave[:, 1]), np.fmin(leave[:, 2], length))
    return t_in <= t_out
