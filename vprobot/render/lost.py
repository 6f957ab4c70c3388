"""The points each frame lost to the sensing model, for the video's inset and the summary still.

Only a sensing model that tells its losses apart (structured light's, docs/sensor.md#sensing)
draws here; under the ideal model nothing does, and the pictures are what they were without it.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import LOSS_CAUSES, FrameLosses
from vprobot.episode import EpisodeRecord, PartScene
from vprobot.render.camera import project
from vprobot.render.markers import LOST_RGBA, rgb8
from vprobot.render.overlay import draw_swatch

LOST_RGB = {cause: rgb8(rgba) for cause, rgba in LOST_RGBA.items()}
"""`LOST_RGBA` as 8-bit RGB, for painting images."""


def frame_losses(scene: PartScene | Cell, record: EpisodeRecord) -> list[FrameLosses | None]:
    """Per view of `record`, what its frame lost and why (None where nothing was acquired).

    The frames are measured again with the sensor that took them (the free-flying sensor's for
    a `free` episode), which gives the same frames: noise and dropout are seeded per frame.

    Returns:
        One entry per view; an empty list under a model whose losses are not told apart (the
        ideal one: `SensingModel.loss_stages`), or for a bare cell, which has no sensor of its
        own.
    """
    if not isinstance(scene, PartScene):
        return []
    sensor = scene.free_sensor if record.carrier == "free" else scene.sensor
    if not sensor.sensing.loss_stages():
        return []
    rotation = record.object_pose.rotation
    return [sensor.losses_at(view.sensor_pose, rotation, view.joints)
            if view.sensor_pose is not None else None for view in record.views]


def lost_in_order(losses: FrameLosses) -> list[tuple[str, np.ndarray]]:
    """Each cause with its lost points (world), in drawing order: the rarer, scattered dropout
    first, the shadow last, on top."""
    return [(cause, losses.lost(cause)) for cause in reversed(LOSS_CAUSES)]


def paint_lost(image: np.ndarray, scene: mujoco.MjvScene, losses: FrameLosses,
               size_px: int) -> np.ndarray:
    """A copy of `image`, the view of the updated `scene`, with the lost points painted in
    their cause's colour as squares of `size_px` pixels."""
    out = image.copy()
    height, width = image.shape[:2]
    for cause, points in lost_in_order(losses):
        pixels = project(scene, points, width, height)
        pixels = np.floor(pixels[np.all(np.isfinite(pixels), axis=1)]).astype(np.int64)
        for dy in range(size_px):
            for dx in range(size_px):
                x, y = pixels[:, 0] + dx, pixels[:, 1] + dy
                inside = (x >= 0) & (x < width) & (y >= 0) & (y < height)
                out[y[inside], x[inside]] = LOST_RGB[cause]
    return out


def point_size_px(image_width: int, frame_width: int) -> int:
    """Pixels per side that paint a frame `frame_width` rays wide into an image without gaps."""
    return max(1, math.ceil(image_width / frame_width))


def lost_legend(image: np.ndarray, losses: FrameLosses | None) -> np.ndarray:
    """A copy of `image` with the causes' colours listed in its bottom-left corner, each with
    its count of lost points when a frame's `losses` are shown."""
    canvas = Image.fromarray(image)
    draw = ImageDraw.Draw(canvas)
    size = max(7, image.shape[0] // 14)
    counts = losses.counts() if losses is not None else None
    y = image.shape[0] - len(LOSS_CAUSES) * (size + 1) - 2
    for cause in LOSS_CAUSES:
        text = cause if counts is None else f"{cause} {counts[cause]:,}"
        draw_swatch(draw, 3, y, text, LOST_RGB[cause], size)
        y += size + 1
    return np.asarray(canvas)
