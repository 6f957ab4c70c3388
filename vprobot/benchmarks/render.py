"""Rendering benchmark: offscreen frame rate of the cell and a 10-view rollout video end to end."""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from vprobot.config import Config
from vprobot.episode import PartScene
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.render.camera import aim_overview
from vprobot.render.demo import ring_inspection
from vprobot.render.offscreen import OffscreenView
from vprobot.render.timeline import TimingSettings, episode_timeline
from vprobot.render.video import EpisodeRenderer, render_episode

WIDTH, HEIGHT = 640, 480
ROLLOUT_VIEWS = 10
TARGET_FPS = 30.0
TARGET_ROLLOUT_S = 30.0


def _moving_configurations(scene: PartScene, frames: int) -> np.ndarray:
    """Configurations sweeping the arm from home towards the first views (so frames differ)."""
    joints = scene.cell.joints
    turn = np.zeros(joints.dof)
    turn[0], turn[1], turn[3] = 1.2, -0.4, 0.8
    fractions = np.linspace(0.0, 1.0, frames)[:, None]
    return np.clip(joints.start + fractions * turn, joints.lower, joints.upper)


def measure_cell_fps(scene: PartScene, frames: int) -> float:
    """Frames per second of the bare cell at 640x480 (scene update, render, read-back)."""
    data = scene.cell.make_data()
    configurations = _moving_configurations(scene, frames)
    with OffscreenView(scene.cell.model, WIDTH, HEIGHT) as view:
        aim_overview(view.camera, scene.cell)
        view.update(data)
        view.rgb()  # the first frame pays for shader compilation and buffer set-up
        start = time.perf_counter()
        for q in configurations:
            data.qpos[:] = q
            view.update(data)
            view.rgb()
        return frames / (time.perf_counter() - start)


def measure_video_frame_fps(scene: PartScene, frames: int) -> float:
    """Frames per second of complete video frames (markers, sensor panel, overlay) at 640x480,
    for the moves of a 10-view episode (holds are rendered once, so they are left out)."""
    record = ring_inspection(scene, ROLLOUT_VIEWS)
    moves = [state for state in episode_timeline(record, TimingSettings())
             if state.phase == "move"][:frames]
    with EpisodeRenderer(scene, record, WIDTH, HEIGHT) as renderer:
        renderer.frame(moves[0])
        start = time.perf_counter()
        for state in moves:
            renderer.frame(state)
        return len(moves) / (time.perf_counter() - start)


def measure_rollout(config: Config, directory: Path) -> dict[str, Any]:
    """Load the bundled motor, run a 10-view inspection, write its 640x480 video; timed."""
    start = time.perf_counter()
    scene = PartScene.load(config, DEFAULT_MOTOR)
    loaded = time.perf_counter()
    record = ring_inspection(scene, ROLLOUT_VIEWS)
    inspected = time.perf_counter()
    video = render_episode(scene, record, directory / "rollout.mp4", width=WIDTH, height=HEIGHT)
    written = time.perf_counter()
    return {
        "rollout_10_views_s": written - start,
        "rollout_scene_load_s": loaded - start,
        "rollout_inspection_s": inspected - loaded,
        "rollout_video_s": written - inspected,
        "rollout_video_frames": video.frames,
        "rollout_video_rendered_frames": video.rendered,
        "rollout_video_seconds": video.duration_s,
        "rollout_video_bytes": video.path.stat().st_size,
        "rollout_views_reached": sum(view.reachable for view in record.views),
        "rollout_coverage": record.coverage,
    }


def run_render_benchmark(config: Config, frames: int = 150) -> dict[str, Any]:
    """Measure the rendering targets on the bundled test motor.

    Args:
        config: Cell and sensor settings (the rollout acquires at the sensor's resolution).
        frames: Frames per frame-rate measurement.

    Returns:
        `render_fps_640x480` (bare cell), `video_frame_fps_640x480` (complete frames),
        `rollout_10_views_s` (end to end, with its parts), the targets, and whether they are met.
    """
    with tempfile.TemporaryDirectory() as directory:
        rollout = measure_rollout(config, Path(directory))
    scene = PartScene.load(config, DEFAULT_MOTOR)
    results: dict[str, Any] = {
        "render_fps_640x480": measure_cell_fps(scene, frames),
        "video_frame_fps_640x480": measure_video_frame_fps(scene, frames),
        **rollout,
        "mujoco_gl": os.environ.get("MUJOCO_GL", "egl"),
        "target_render_fps": TARGET_FPS,
        "target_rollout_s": TARGET_ROLLOUT_S,
    }
    results["render_fps_met"] = results["render_fps_640x480"] >= TARGET_FPS
    results["rollout_time_met"] = results["rollout_10_views_s"] <= TARGET_ROLLOUT_S
    return results
