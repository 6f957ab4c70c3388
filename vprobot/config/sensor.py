"""The sensor's frustum geometry, in one place: a pinhole grid of rays (docs/sensor.md).

Sensor frame, used throughout vprobot: +z is the viewing direction, +x is image right, +y is image
down. Pixel (row i, column j) of a w x h frame looks along (u_j, v_i, 1), where u and v are the
pixel centres of an even grid over ±tan(fov_x / 2) and ±tan(fov_y / 2); frames are row-major. A
point is measured when it lies in the frustum at a ray distance within [near, far].

Acquisition (`vprobot.cell.sensor`), ground truth, the planners' visibility prediction and the
renderer all take this geometry from a `SensorModel`; none of them derives it from the config.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from vprobot.config import SensorConfig, check_sensor
from vprobot.geometry.poses import Pose


@dataclasses.dataclass(frozen=True)
class SensorModel:
    """A pinhole depth sensor: its ray grid, opening angles and range.

    Attributes:
        resolution: Rays along image x and y (width, height).
        fov_deg: Full opening angles along image x and y.
        near_m: Hits closer than this (along the ray) are dropped.
        far_m: Hits farther than this are dropped.
        working_distance_m: Optimal distance from the sensor to the object's centre.

    Raises:
        ConfigError: A ValueError, if `vprobot.config.check_sensor` (the same check as a
            configured sensor's) rejects the geometry.
    """

    resolution: tuple[int, int]
    fov_deg: tuple[float, float]
    near_m: float
    far_m: float
    working_distance_m: float

    def __post_init__(self) -> None:
        check_sensor(self.resolution, self.fov_deg, self.near_m, self.far_m,
                     self.working_distance_m)
        object.__setattr__(self, "resolution", tuple(int(rays) for rays in self.resolution))
        object.__setattr__(self, "fov_deg", tuple(float(angle) for angle in self.fov_deg))

    @classmethod
    def from_config(cls, sensor: SensorConfig) -> SensorModel:
        """The model of a configured sensor (the mount is the cell's business, not the model's)."""
        return cls(resolution=sensor.resolution, fov_deg=sensor.fov_deg, near_m=sensor.near_m,
                   far_m=sensor.far_m, working_distance_m=sensor.working_distance_m)

    def at_resolution(self, resolution: tuple[int, int]) -> SensorModel:
        """The same opening angles and range over another grid, e.g. training's coarser frame.

        Raises:
            ConfigError: If the resolution is not two integers in 1..MAX_RAYS_PER_AXIS.
        """
        return dataclasses.replace(self, resolution=resolution)

    @property
    def rays_per_frame(self) -> int:
        return self.resolution[0] * self.resolution[1]

    @functools.cached_property
    def half_tangents(self) -> tuple[float, float]:
        """tan(fov / 2) along image x and y: the frustum's edges at unit depth."""
        half_x = np.tan(np.deg2rad(self.fov_deg[0]) / 2.0)
        half_y = np.tan(np.deg2rad(self.fov_deg[1]) / 2.0)
        return float(half_x), float(half_y)

    @functools.cached_property
    def pixel_tangents(self) -> tuple[np.ndarray, np.ndarray]:
        """Tangents of the pixel centres along image x (w,) and image y (h,), read-only."""
        (width, height), (half_x, half_y) = self.resolution, self.half_tangents
        u = half_x * ((2.0 * np.arange(width) + 1.0) / width - 1.0)
        v = half_y * ((2.0 * np.arange(height) + 1.0) / height - 1.0)
        u.setflags(write=False)
        v.setflags(write=False)
        return u, v

    @functools.cached_property
    def ray_directions(self) -> np.ndarray:
        """Unit ray directions (h * w, 3) in the sensor frame, row-major, read-only."""
        u, v = self.pixel_tangents
        grid_u, grid_v = np.meshgrid(u, v)
        directions = np.stack([grid_u, grid_v, np.ones_like(grid_u)], axis=-1).reshape(-1, 3)
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        directions.setflags(write=False)
        return directions

    @functools.cached_property
    def cone_angle_rad(self) -> float:
        """Half-angle of the cone around +z that holds every ray of the grid."""
        u, v = self.pixel_tangents
        return float(np.arctan(np.hypot(u[-1], v[-1])))

    @property
    def inscribed_cone_angle_rad(self) -> float:
        """Half-angle of the widest cone around +z that lies inside the frustum."""
        return math.radians(min(self.fov_deg) / 2.0)

    def frustum_corners(self, pose: Pose, distance: float) -> np.ndarray:
        """The four corners (4, 3) of the frustum's cross-section at `distance` along the view
        axis, in the world, clockwise in the image from its top left."""
        half_x, half_y = np.asarray(self.half_tangents) * distance
        local = np.array([[-half_x, -half_y, distance], [half_x, -half_y, distance],
                          [half_x, half_y, distance], [-half_x, half_y, distance]])
        return local @ pose.rotation.T + pose.position

    def in_range(self, distance: np.ndarray) -> np.ndarray:
        """Whether ray distances lie within [near, far]."""
        return (distance >= self.near_m) & (distance <= self.far_m)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """Whether points (..., 3) in the sensor frame lie in the frustum and within range."""
        x, y, z = points[..., 0], points[..., 1], points[..., 2]
        half_x, half_y = self.half_tangents
        distance = np.sqrt(x * x + y * y + z * z)
        return ((z > 0.0) & (np.abs(x) <= half_x * z) & (np.abs(y) <= half_y * z)
                & self.in_range(distance))
