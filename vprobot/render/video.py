"""Rollout videos: the arm moving between views, frusta, acquired points and a status overlay."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
from tqdm import tqdm

from vprobot.cell.scene import Cell
from vprobot.cell.sensor import FrameLosses
from vprobot.config.sensor import SensorModel
from vprobot.episode import EpisodeRecord, PartScene, ViewRecord
from vprobot.kinematics import TravelCost
from vprobot.render.camera import aim_overview
from vprobot.render.closeup import PartCloseUp
from vprobot.render.lost import frame_losses, lost_legend, paint_lost, point_size_px
from vprobot.render.markers import (
    FRUSTUM_SEGMENTS,
    UNREACHABLE_RGBA,
    add_frustum,
    add_points,
    subsample,
    view_rgba,
)
from vprobot.render.offscreen import OffscreenView, check_size
from vprobot.render.output import VideoWriter
from vprobot.render.overlay import OverlayStatus, draw_status, inset
from vprobot.render.panel import PanelMode, SensorPanel
from vprobot.render.timeline import FrameState, TimingSettings, episode_timeline

POINT_SIZE_M = 0.004
TARGET_RGBA = np.array([1.0, 1.0, 1.0, 0.6], dtype=np.float32)
FADED_ALPHA = 0.35
PANEL_FRACTION = 0.32
"""Width of the sensor panel as a fraction of the frame width."""


@dataclasses.dataclass(frozen=True)
class RenderedVideo:
    """A written video.

    Attributes:
        path: The file.
        frames: Frames written.
        duration_s: Length of the video.
        rendered: Distinct frames rendered (holds are rendered once and repeated).
    """

    path: Path
    frames: int
    duration_s: float
    rendered: int


def cell_of(scene: PartScene | Cell) -> Cell:
    """The cell of a part's scene, or the cell itself."""
    return scene.cell if isinstance(scene, PartScene) else scene


class EpisodeRenderer:
    """Draws the frames of one episode in its cell.

    Args:
        scene: The part's scene (or its cell) the episode ran in.
        record: The episode.
        width: Frame width in pixels.
        height: Frame height in pixels.
        sensor_panel: Inset the sensor's own view (`color` or `depth`), or None. Under a
            structured-light sensor, while a view the robot took is shown, the points its frame
            lost are painted on it by cause (`vprobot.render.lost`), with a legend.
        points_per_view: Acquired points drawn per view (a random subset; drawing is per point).
        part_close_up: Inset a close-up of the part with its ground-truth points covered so far
            (green) and not (red), bottom left (`vprobot.render.closeup`).

    Raises:
        ValueError: For a bad size, panel mode or point count, or an episode with no views.
    """

    def __init__(self, scene: PartScene | Cell, record: EpisodeRecord, width: int = 640,
                 height: int = 480, sensor_panel: PanelMode | None = "color",
                 points_per_view: int = 200, part_close_up: bool = True):
        width, height = check_size(width, height)
        if points_per_view < 0:
            raise ValueError(f"points_per_view must be >= 0, got {points_per_view}")
        if not record.views:
            raise ValueError("the episode has no views to render")
        self.cell = cell_of(scene)
        self.record = record
        self.sensor = SensorModel.from_config(self.cell.config.sensor)
        self.data = self.cell.make_data()
        self.cell.place_object(self.data, record.object_pose.rotation)
        self.points = [subsample(view.points_world, points_per_view, seed=index)
                       for index, view in enumerate(record.views)]
        markers = sum(2 * FRUSTUM_SEGMENTS + len(points) for points in self.points)
        self.view = OffscreenView(self.cell.model, width, height,
                                  max_geom=markers + FRUSTUM_SEGMENTS)
        aim_overview(self.view.camera, self.cell)
        self.panel = (None if sensor_panel is None else
                      SensorPanel(self.cell, max(8, int(PANEL_FRACTION * width)), sensor_panel))
        self.close_up = (PartCloseUp(self.cell, self.data, record,
                                     max(8, int(PANEL_FRACTION * width)))
                         if part_close_up and isinstance(scene, PartScene) else None)
        # The panel is the robot's sensor camera: it shows a view only where the robot took it.
        self.losses: list[FrameLosses | None] = []
        if self.panel is not None and record.carrier == "robot" and isinstance(scene, PartScene):
            self.losses = frame_losses(scene, record)
            if self.losses:
                self.lost_size_px = point_size_px(self.panel.width, scene.sensor.resolution[0])

    def frame(self, state: FrameState) -> np.ndarray:
        """The frame (height, width, 3) uint8 showing `state`."""
        self.data.qpos[:] = state.joints
        mujoco.mj_kinematics(self.cell.model, self.data)
        self.view.update(self.data, lambda scene: self._draw_markers(scene, state))
        frame = self.view.rgb()
        if self.panel is not None:
            frame = inset(frame, self._panel(self.panel, state), f"sensor ({self.panel.mode})")
        if self.close_up is not None:
            frame = inset(frame, self.close_up.render(state.shown), "part: covered green",
                          left=True)
        return draw_status(frame, self.status(state))

    def _panel(self, sensor_panel: SensorPanel, state: FrameState) -> np.ndarray:
        """The sensor's view; with what the shown view's frame lost, and the legend, where
        frames lose points."""
        panel = sensor_panel.render(self.data)
        if not self.losses:
            return panel
        shown = self.losses[state.view] if state.phase in ("acquire", "end") else None
        if shown is not None:
            panel = paint_lost(panel, sensor_panel.view.scene, shown, self.lost_size_px)
        return lost_legend(panel, shown)

    def _draw_markers(self, scene: mujoco.MjvScene, state: FrameState) -> None:
        for index, view in enumerate(self.record.views[: state.shown]):
            latest = index == state.shown - 1 and state.phase in ("acquire", "unreachable")
            if not view.reachable:
                add_frustum(scene, self.sensor, view.requested, self.sensor.far_m,
                            UNREACHABLE_RGBA, 3.0 if latest else 1.5)
            if view.sensor_pose is not None:
                rgba = view_rgba(index, 1.0 if latest else FADED_ALPHA)
                add_frustum(scene, self.sensor, view.sensor_pose, self.sensor.far_m,
                            rgba, 3.0 if latest else 1.5)
                add_points(scene, self.points[index], view_rgba(index), POINT_SIZE_M)
        if state.phase == "move":
            target = self.record.views[state.view].requested
            add_frustum(scene, self.sensor, target, self.sensor.far_m, TARGET_RGBA, 1.0)

    def status(self, state: FrameState) -> OverlayStatus:
        """The overlay's text for `state`."""
        views = self.record.views
        done = views[: state.shown]
        travel = sum((view.travel for view in done), TravelCost())
        if state.phase == "move":
            current = views[state.view].travel
            travel = travel + TravelCost(*(state.progress * value
                                           for value in current.as_dict().values()))
        return OverlayStatus(
            step=state.view + 1,
            steps=len(views),
            caption=self._caption(state),
            coverage=done[-1].coverage if done else 0.0,
            joint_time_s=travel.joint_time,
            sensor_path_m=travel.cartesian,
            unreachable=tuple((index + 1, view.reason or "unreachable")
                              for index, view in enumerate(done) if not view.reachable),
            clock_s=state.clock_s,
            cycle_s=None if self.record.timed is None else self.record.timed.duration_s,
        )

    def _caption(self, state: FrameState) -> str:
        number = state.view + 1
        if state.phase == "start":
            return "start"
        if state.phase == "move":
            return f"moving to view {number}"
        if state.phase == "unreachable":
            return "unreachable"
        if state.phase == "return":
            return "returning home"
        if state.phase in ("end", "home"):
            return "done"
        return f"acquired (+{100.0 * _gain(self.record.views, state.view):.1f} %)"

    def timeline(self, settings: TimingSettings) -> list[FrameState]:
        """The episode's frame states (`episode_timeline`), on the cell's clock where the robot's
        cycle is timed."""
        return episode_timeline(self.record, settings, self.record.timed)

    def frames(self, settings: TimingSettings) -> Iterator[tuple[np.ndarray, int]]:
        """Each distinct frame of the episode with how many times it repeats."""
        for state in self.timeline(settings):
            yield self.frame(state), state.repeat

    def close(self) -> None:
        """Free the OpenGL resources."""
        self.view.close()
        if self.panel is not None:
            self.panel.close()
        if self.close_up is not None:
            self.close_up.close()

    def __enter__(self) -> EpisodeRenderer:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def _gain(views: list[ViewRecord], index: int) -> float:
    """Coverage added by view `index`."""
    before = views[index - 1].coverage if index > 0 else 0.0
    return views[index].coverage - before


def render_episode(
    scene: PartScene | Cell,
    record: EpisodeRecord,
    out_path: str | Path,
    *,
    width: int = 640,
    height: int = 480,
    fps: float = 30.0,
    time_scale: float = 1.0,
    max_seconds_per_move: float = 2.0,
    hold_seconds: float = 0.6,
    sensor_panel: PanelMode | None = "color",
    points_per_view: int = 200,
    progress: bool = False,
) -> RenderedVideo:
    """Render an episode to an MP4 (H.264) or, for a `.gif` path, an animated GIF.

    The video keeps the cell's clock (`vprobot.render.timeline`): the arm follows the robot's
    timed trajectory, each move lasting its duration under the robot's limits times
    `time_scale` (capped at `max_seconds_per_move`), and returns home at the end; the overlay
    shows the elapsed cycle time and the cycle time. Each acquisition is held for
    `hold_seconds` with its frustum and points, which stay (faded) afterwards. Unreachable
    requests show as red frusta at the requested pose. Without a cycle (a free-flying sensor,
    or no path home) the moves are timed by their joint time and there is no clock. The file
    is written atomically.

    Args:
        scene: The part's scene (or cell) the episode ran in.
        record: The episode (`Episode.record()`, or `episode_from_plan`).
        out_path: `.mp4` or `.gif` file in an existing folder.
        width: Frame width in pixels (even for MP4).
        height: Frame height in pixels (even for MP4).
        fps: Frames per second.
        time_scale: Video seconds per second of the robot's time (the cell's clock).
        max_seconds_per_move: Cap on the video time of one move.
        hold_seconds: Time each acquisition is shown.
        sensor_panel: `color` or `depth` inset of the sensor's view, or None.
        points_per_view: Acquired points drawn per view.
        progress: Show a progress bar.

    Raises:
        ValueError: For a bad output path (missing folder, a folder, a suffix other than .mp4 or
            .gif), size, timing or panel mode, or an episode without views.
    """
    settings = TimingSettings(fps=fps, time_scale=time_scale,
                              max_seconds_per_move=max_seconds_per_move,
                              hold_seconds=hold_seconds)
    width, height = check_size(width, height)
    writer = VideoWriter(out_path, fps, width, height)
    rendered = 0
    with EpisodeRenderer(scene, record, width, height, sensor_panel, points_per_view) as renderer, \
            writer:
        total = sum(state.repeat for state in renderer.timeline(settings))
        with tqdm(total=total, desc="frames", disable=not progress, leave=False) as bar:
            for frame, repeat in renderer.frames(settings):
                for _ in range(repeat):
                    writer.append(frame)
                rendered += 1
                bar.update(repeat)
    return RenderedVideo(writer.path, writer.frames, writer.frames / fps, rendered)
