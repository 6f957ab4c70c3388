"""A still that sums up an inspection: which ground-truth points are covered, and from where.

Left, the views: the object with its ground-truth points, the view poses as small numbered
frusta and the sensor's track between them. Right, two close-ups of the object from opposite
sides, where covered (green) and uncovered (red) points can be told apart. Under a
structured-light sensor the close-ups also show the points each frame lost, by cause
(`vprobot.render.lost`), and the caption counts them.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import LOSS_CAUSES, FrameLosses
from vprobot.config.sensor import SensorModel
from vprobot.episode import EpisodeRecord, PartScene, describe_cycle
from vprobot.geometry.poses import Pose
from vprobot.render.camera import aim_at_sphere, project
from vprobot.render.closeup import FRAME_MARGIN, draw_coverage, hide_robot
from vprobot.render.lost import LOST_RGB, frame_losses, lost_in_order
from vprobot.render.markers import (
    FRUSTUM_SEGMENTS,
    LOST_RGBA,
    UNREACHABLE_RGBA,
    add_frustum,
    add_points,
    add_segment,
    subsample,
    view_rgba,
)
from vprobot.render.offscreen import OffscreenView, check_size
from vprobot.render.output import check_output_path, write_png
from vprobot.render.overlay import BOX_RGBA, TEXT_RGB, draw_swatch, font
from vprobot.render.video import cell_of

OVERVIEW_FRACTION = 0.6
"""Share of the width taken by the overview; the close-ups share the rest."""
OVERVIEW_DIRECTION_DEG = (-150.0, -30.0)
CLOSE_UP_DIRECTIONS_DEG = ((-150.0, -35.0), (30.0, 20.0))
"""(azimuth, elevation) of the cameras: the close-ups look at opposite sides, from above and
from below."""
OVERVIEW_POINT_SIZE_M = 0.003
CLOSE_UP_POINT_SIZE_M = 0.0025
SMALL_FRUSTUM_M = 0.09
"""Depth of the frusta drawn at the view poses: enough to show the direction."""
TRACK_RGBA = np.array([1.0, 1.0, 1.0, 0.5], dtype=np.float32)
LOST_POINTS_PER_VIEW = 300
"""Lost points drawn per view and cause (a random subset: drawing is per point)."""
MIN_PANEL_PX = 16


def _sensor_track(cell: Cell, record: EpisodeRecord) -> np.ndarray:
    """Sensor positions (n, 3) along all of the episode's joint-space moves."""
    data = cell.make_data()
    positions = []
    for view in record.views:
        for q in view.path if view.path is not None else ():
            data.qpos[:] = q
            mujoco.mj_kinematics(cell.model, data)
            positions.append(data.site_xpos[cell.sensor_site_id].copy())
    return np.array(positions).reshape(-1, 3)


def _view_poses(record: EpisodeRecord) -> list[Pose]:
    """Where each view was taken from, or for an unreachable one, where it was requested."""
    return [view.sensor_pose if view.sensor_pose is not None else view.requested
            for view in record.views]


def _overview(cell: Cell, data: mujoco.MjData, record: EpisodeRecord, width: int,
              height: int) -> np.ndarray:
    """The object, the numbered view frusta and the sensor's track."""
    track = _sensor_track(cell, record)
    poses = _view_poses(record)
    geoms = len(record.gt_points_world) + len(track) + FRUSTUM_SEGMENTS * len(poses)
    sensor = SensorModel.from_config(cell.config.sensor)
    with OffscreenView(cell.model, width, height, fine=True, max_geom=geoms) as view:
        hide_robot(view, cell)
        positions = np.array([pose.position for pose in poses] + [record.object_pose.position])
        center = (positions.min(axis=0) + positions.max(axis=0)) / 2.0
        radius = float(np.max(np.linalg.norm(positions - center, axis=1)))
        aim_at_sphere(view.camera, view.model, center, FRAME_MARGIN * radius,
                      *OVERVIEW_DIRECTION_DEG)

        def draw(scene: mujoco.MjvScene) -> None:
            draw_coverage(scene, record, OVERVIEW_POINT_SIZE_M)
            for start, end in itertools.pairwise(track):
                add_segment(scene, start, end, TRACK_RGBA, 1.5)
            for index, (pose, view_record) in enumerate(zip(poses, record.views, strict=True)):
                rgba = view_rgba(index) if view_record.reachable else UNREACHABLE_RGBA
                add_frustum(scene, sensor, pose, SMALL_FRUSTUM_M, rgba, 2.5)

        view.update(data, draw)
        image = view.rgb()
        labels = project(view.scene, positions[:-1], width, height)
    return _label_views(image, record, labels)


def _lost_points(losses: list[FrameLosses | None]) -> list[tuple[str, np.ndarray]]:
    """Each view's lost points per cause, subsampled, in drawing order."""
    return [(cause, subsample(points, LOST_POINTS_PER_VIEW, seed=index))
            for index, view_losses in enumerate(losses) if view_losses is not None
            for cause, points in lost_in_order(view_losses)]


def _close_ups(cell: Cell, data: mujoco.MjData, record: EpisodeRecord,
               losses: list[FrameLosses | None], width: int, height: int) -> np.ndarray:
    """The object from two opposite sides, stacked, with the points the frames lost."""
    radius = float(np.max(np.linalg.norm(cell.object_vertices, axis=1)))
    lost = _lost_points(losses)

    def draw(scene: mujoco.MjvScene) -> None:
        draw_coverage(scene, record, CLOSE_UP_POINT_SIZE_M)
        for cause, points in lost:
            add_points(scene, points, LOST_RGBA[cause], CLOSE_UP_POINT_SIZE_M)

    images = []
    geoms = len(record.gt_points_world) + sum(len(points) for _, points in lost)
    with OffscreenView(cell.model, width, height // 2, fine=True, max_geom=geoms) as view:
        hide_robot(view, cell)
        for azimuth, elevation in CLOSE_UP_DIRECTIONS_DEG:
            aim_at_sphere(view.camera, view.model, record.object_pose.position,
                          FRAME_MARGIN * radius, azimuth, elevation)
            view.update(data, draw)
            images.append(view.rgb())
    stacked = np.concatenate(images, axis=0)
    # An odd height leaves one row for the close-ups to fill.
    return np.pad(stacked, ((0, height - stacked.shape[0]), (0, 0), (0, 0)), mode="edge")


def _label_views(image: np.ndarray, record: EpisodeRecord, labels: np.ndarray) -> np.ndarray:
    canvas = Image.fromarray(image)
    draw = ImageDraw.Draw(canvas)
    size = max(10, image.shape[0] // 30)
    for index, (x, y) in enumerate(labels):
        if np.isfinite(x) and np.isfinite(y):
            mark = "" if record.views[index].reachable else " x"
            draw.text((x + 4, y - size), f"{index + 1}{mark}", font=font(size), fill=TEXT_RGB,
                      stroke_width=2, stroke_fill=(0, 0, 0))
    return np.asarray(canvas)


def _caption(image: np.ndarray, record: EpisodeRecord, losses: list[FrameLosses | None],
             cycle: str | None) -> np.ndarray:
    """The episode's totals across the top, with the robot's `cycle` time (`describe_cycle`);
    where frames lose points, a line more: how many each cause lost (in its colour in the
    close-ups) and how many were measured, summed over the frames."""
    covered = int(np.count_nonzero(record.covered))
    reached = sum(view.reachable for view in record.views)
    travel = record.travel_sum
    lines = [
        f"coverage {100.0 * record.coverage:.1f} %: {covered} of {len(record.covered)} "
        "ground-truth points covered (green), the rest not (red)",
        f"{reached} of {len(record.views)} views reached (x: unreachable request); between "
        f"views {travel.joint_time:.2f} s joint time, {travel.cartesian:.2f} m sensor path",
        *([] if cycle is None else [cycle]),
    ]
    frames = [view_losses.counts() for view_losses in losses if view_losses is not None]
    canvas = Image.fromarray(image).convert("RGBA")
    layer = Image.new("RGBA", canvas.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    size = max(9, image.shape[0] // 40)
    margin = max(2, size // 2)
    rows = len(lines) + bool(frames)
    draw.rectangle((0, 0, canvas.size[0], 2 * margin + rows * (size + margin)), fill=BOX_RGBA)
    for row, line in enumerate(lines):
        draw.text((margin, margin + row * (size + margin)), line, font=font(size),
                  fill=TEXT_RGB)
    if frames:
        y = margin + len(lines) * (size + margin)
        text = "points the frames lost (another view may measure them):"
        draw.text((margin, y), text, font=font(size), fill=TEXT_RGB)
        x = 2 * margin + int(font(size).getlength(text))
        for cause in LOSS_CAUSES:
            total = sum(counts[cause] for counts in frames)
            x = draw_swatch(draw, x, y, f"{cause} {total:,}", LOST_RGB[cause], size)
        measured = sum(counts["measured"] for counts in frames)
        draw.text((x, y), f"measured {measured:,}", font=font(size), fill=TEXT_RGB)
    return np.asarray(Image.alpha_composite(canvas, layer).convert("RGB"))


def render_summary(scene: PartScene | Cell, record: EpisodeRecord, out_png: str | Path,
                   width: int = 1280, height: int = 720) -> Path:
    """Write a PNG summing up an episode: coverage of the ground truth and the view poses,
    with the robot's cycle time and its parts (docs/motion.md#cycle-time).

    Under a structured-light sensor it also shows the points each frame lost, by cause, and
    their totals; each frame is measured again for that (`vprobot.render.lost.frame_losses`).

    Args:
        scene: The part's scene (or cell) the episode ran in.
        record: The episode.
        out_png: `.png` file in an existing folder (written atomically).
        width: Image width in pixels.
        height: Image height in pixels.

    Raises:
        ValueError: For a bad output path, a size below 16 pixels per panel, or an episode
            without views.
    """
    out_png = check_output_path(out_png, (".png",))
    width, height = check_size(width, height)
    overview_width = round(OVERVIEW_FRACTION * width)
    if min(overview_width, width - overview_width, height // 2) < MIN_PANEL_PX:
        raise ValueError(f"summary size {width}x{height} is too small for its three panels")
    if not record.views:
        raise ValueError("the episode has no views to summarise")
    cell = cell_of(scene)
    data = cell.make_data()
    cell.place_object(data, record.object_pose.rotation)
    losses = frame_losses(scene, record)
    image = np.concatenate([
        _overview(cell, data, record, overview_width, height),
        _close_ups(cell, data, record, losses, width - overview_width, height),
    ], axis=1)
    cycle = describe_cycle(record)
    return write_png(out_png, _caption(image, record, losses, cycle))
