"""Where the renderer's free camera looks from, and projecting world points into its image."""

from __future__ import annotations

import mujoco
import numpy as np

from vprobot.cell.scene import Cell

OVERVIEW_AZIMUTH_DEG = -135.0
OVERVIEW_ELEVATION_DEG = -18.0
OVERVIEW_DISTANCE = 0.9
"""Camera distance per metre of arm length: the arm around the object in view, not the floor."""
OVERVIEW_FOCUS = 0.8
OVERVIEW_RAISE_M = 0.2
"""The camera looks at the point OVERVIEW_FOCUS of the way from the robot base to the object,
raised by OVERVIEW_RAISE_M: the views happen around the object, the elbow above it."""


def arm_length(cell: Cell) -> float:
    """Sum of the link offsets from the robot base to the sensor (m): how far the arm can reach."""
    model = cell.model
    base = cell.base_body_id
    body = cell.sensor_body_id
    length = 0.0
    while body not in (base, 0):
        length += float(np.linalg.norm(model.body_pos[body]))
        body = model.body_parentid[body]
    return length


def _overview_target(cell: Cell) -> np.ndarray:
    base = cell.robot_base.position
    return base + OVERVIEW_FOCUS * (cell.object_center - base) + [0.0, 0.0, OVERVIEW_RAISE_M]


def aim_overview(camera: mujoco.MjvCamera, cell: Cell) -> None:
    """Frame the object and the arm around it from the front left, slightly above."""
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = _overview_target(cell)
    camera.distance = OVERVIEW_DISTANCE * arm_length(cell)
    camera.azimuth = OVERVIEW_AZIMUTH_DEG
    camera.elevation = OVERVIEW_ELEVATION_DEG


def overview_eye(cell: Cell) -> tuple[np.ndarray, np.ndarray]:
    """Where `aim_overview`'s camera is and the point it looks at (world), for a viewer that
    places its camera by those two points."""
    target = _overview_target(cell)
    azimuth, elevation = np.deg2rad(OVERVIEW_AZIMUTH_DEG), np.deg2rad(OVERVIEW_ELEVATION_DEG)
    # MuJoCo's free camera looks along this direction from `distance` behind its look-at point.
    forward = np.array([np.cos(elevation) * np.cos(azimuth),
                        np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    return target - OVERVIEW_DISTANCE * arm_length(cell) * forward, target


def aim_at_sphere(camera: mujoco.MjvCamera, model: mujoco.MjModel, center: np.ndarray,
                  radius_m: float, azimuth_deg: float, elevation_deg: float) -> None:
    """Point the free camera at `center` from the given direction, just far enough away that a
    sphere of `radius_m` fits the (vertical) field of view."""
    half_fov = np.deg2rad(model.vis.global_.fovy) / 2.0
    camera.type = mujoco.mjtCamera.mjCAMERA_FREE
    camera.lookat[:] = center
    camera.distance = radius_m / np.sin(half_fov)
    camera.azimuth = azimuth_deg
    camera.elevation = elevation_deg


def project(scene: mujoco.MjvScene, points: np.ndarray, width: int,
            height: int) -> np.ndarray:
    """Pixel coordinates (n, 2) of world `points` (n, 3) in the image of an updated `scene`.

    Points behind the camera get NaN.
    """
    camera = scene.camera[0]
    forward = np.asarray(camera.forward, dtype=float)
    up = np.asarray(camera.up, dtype=float)
    right = np.cross(forward, up)
    relative = np.asarray(points, dtype=float) - np.asarray(camera.pos, dtype=float)
    depth = relative @ forward
    with np.errstate(divide="ignore", invalid="ignore"):
        x = camera.frustum_near * (relative @ right) / depth
        y = camera.frustum_near * (relative @ up) / depth
    # A zero width means "from the viewport's aspect ratio", as mjr_render resolves it.
    half_width = camera.frustum_width or (
        (camera.frustum_top - camera.frustum_bottom) / 2.0 * width / height)
    u = (x - camera.frustum_center + half_width) / (2.0 * half_width) * width
    v = (camera.frustum_top - y) / (camera.frustum_top - camera.frustum_bottom) * height
    pixels = np.column_stack([u, v])
    pixels[depth <= 0] = np.nan
    return pixels
