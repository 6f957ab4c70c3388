"""Extra geoms drawn into a MuJoCo scene: sensor frusta, point clouds, per-view colours."""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.cell.sensor import LOSS_CAUSES
from vprobot.config.sensor import SensorModel
from vprobot.geometry.poses import Pose

VIEW_COLORS = np.array([
    [0.12, 0.47, 0.71], [1.00, 0.50, 0.05], [0.58, 0.40, 0.74], [0.09, 0.75, 0.81],
    [0.89, 0.47, 0.76], [0.74, 0.74, 0.13], [0.55, 0.34, 0.29], [0.90, 0.90, 0.90],
    [0.25, 0.25, 0.75], [1.00, 0.85, 0.20],
])
"""One colour per view, cycled (tab10-like without red and green, which mean coverage)."""
UNREACHABLE_RGBA = np.array([0.95, 0.1, 0.1, 0.55], dtype=np.float32)
COVERED_RGBA = np.array([0.1, 0.85, 0.2, 1.0], dtype=np.float32)
UNCOVERED_RGBA = np.array([0.95, 0.12, 0.1, 1.0], dtype=np.float32)
LOST_RGBA = {cause: np.append(np.frombuffer(bytes.fromhex(code), np.uint8) / 255.0, 1.0)
             for cause, code in zip(LOSS_CAUSES, ("9c3fd6", "17becf", "1a1a1a"), strict=True)}
"""The colour of the points a frame lost, per cause (`vprobot.cell.sensor.LOSS_CAUSES`): shadowed
purple, grazing cyan, apart from coverage's green and red and the motor's orange; dropped out
near black, as the depth panel draws no return."""
FRUSTUM_SEGMENTS = 8
"""Geoms per frustum: four edges from the optical centre and the far rectangle."""

_IDENTITY = np.eye(3).ravel()


def view_rgba(index: int, alpha: float = 1.0) -> np.ndarray:
    """The colour of view `index` (0-based) with opacity `alpha`."""
    return np.append(VIEW_COLORS[index % len(VIEW_COLORS)], alpha).astype(np.float32)


def rgb8(rgba: np.ndarray) -> tuple[int, int, int]:
    """An RGBA colour of floats in [0, 1] as 8-bit RGB, for images and web pages."""
    red, green, blue = (round(255 * float(channel)) for channel in rgba[:3])
    return red, green, blue


def subsample(points: np.ndarray, count: int, seed: int = 0) -> np.ndarray:
    """At most `count` of `points` (n, 3), chosen at random but reproducibly."""
    if len(points) <= count:
        return points
    rng = np.random.default_rng(seed)
    return points[np.sort(rng.choice(len(points), size=count, replace=False))]


def _next_geom(scene: mujoco.MjvScene) -> mujoco.MjvGeom | None:
    # Like MuJoCo itself, drop what does not fit rather than fail a whole video over a marker.
    if scene.ngeom >= scene.maxgeom:
        return None
    geom = scene.geoms[scene.ngeom]
    scene.ngeom += 1
    return geom


def add_segment(scene: mujoco.MjvScene, start: np.ndarray, end: np.ndarray, rgba: np.ndarray,
                width_px: float) -> None:
    """A line from `start` to `end`, `width_px` pixels wide."""
    geom = _next_geom(scene)
    if geom is None:
        return
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_LINE, np.zeros(3), np.zeros(3), _IDENTITY,
                        rgba)
    mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_LINE, width_px,
                         np.asarray(start, dtype=float), np.asarray(end, dtype=float))


def add_frustum(scene: mujoco.MjvScene, sensor: SensorModel, pose: Pose, distance: float,
                rgba: np.ndarray, width_px: float = 2.0) -> None:
    """The sensor's viewing pyramid at `pose`, out to `distance` along the view axis.

    The near bound is left out: four more lines per view clutter the picture more than they
    tell.
    """
    far = sensor.frustum_corners(pose, distance)
    for corner in range(4):
        add_segment(scene, pose.position, far[corner], rgba, width_px)
        add_segment(scene, far[corner], far[(corner + 1) % 4], rgba, width_px)


def add_points(scene: mujoco.MjvScene, points: np.ndarray, rgba: np.ndarray,
               size_m: float) -> None:
    """Small cubes at `points` (n, 3).

    Cubes, not spheres: a sphere costs hundreds of triangles, which software OpenGL feels at
    thousands of points.
    """
    size = np.full(3, size_m / 2.0)
    for point in np.asarray(points, dtype=float):
        geom = _next_geom(scene)
        if geom is None:
            return
        mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_BOX, size, point, _IDENTITY, rgba)
        # No highlights, some glow: the default specular washes small cubes out towards white.
        geom.specular = 0.0
        geom.emission = 0.3
