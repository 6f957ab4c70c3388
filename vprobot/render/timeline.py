"""The frames of an episode video: where the arm is and how far the episode has got, per frame.

Pure bookkeeping, no OpenGL: the arm moves along each view's joint-space path, eased in and out
and timed by the move's joint time (the synchronous point-to-point time at the velocity limits),
then holds while the acquisition is shown.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np

from vprobot.episode import EpisodeRecord

Phase = Literal["start", "move", "acquire", "unreachable", "end"]


@dataclasses.dataclass(frozen=True)
class TimingSettings:
    """How episode time maps to video frames.

    Attributes:
        fps: Video frames per second.
        time_scale: Video seconds per second of robot joint time (1 = real time).
        max_seconds_per_move: Cap on one move's duration in the video.
        hold_seconds: How long each acquisition (or unreachable request) is shown.
        start_seconds: Still frames before the first move.
        end_seconds: Still frames after the last view.
    """

    fps: float = 30.0
    time_scale: float = 1.0
    max_seconds_per_move: float = 2.0
    hold_seconds: float = 0.6
    start_seconds: float = 0.5
    end_seconds: float = 1.5

    def __post_init__(self) -> None:
        if not self.fps > 0:
            raise ValueError(f"fps must be positive, got {self.fps}")
        if not self.time_scale > 0:
            raise ValueError(f"time_scale must be positive, got {self.time_scale}")
        for name in ("max_seconds_per_move", "hold_seconds", "start_seconds", "end_seconds"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")

    def frames(self, seconds: float) -> int:
        return round(seconds * self.fps)


@dataclasses.dataclass(frozen=True)
class FrameState:
    """What one video frame shows.

    Attributes:
        joints: Robot configuration.
        view: Index of the view being moved to or shown (-1 before the first).
        shown: How many views have their outcome drawn (frusta, points, marks).
        progress: Fraction of the current move done (1 outside moves).
        phase: What is happening.
        repeat: How many identical frames this state stands for (holds are rendered once).
    """

    joints: np.ndarray
    view: int
    shown: int
    progress: float
    phase: Phase
    repeat: int = 1


def ease(fraction: np.ndarray) -> np.ndarray:
    """Smoothstep: starts and stops at rest, like a point-to-point robot move."""
    fraction = np.clip(fraction, 0.0, 1.0)
    return fraction * fraction * (3.0 - 2.0 * fraction)


def along_path(path: np.ndarray, fractions: np.ndarray) -> np.ndarray:
    """Configurations at `fractions` of the joint-space arc length of `path` (n, dof)."""
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(steps)])
    if arc[-1] <= 0.0:
        return np.repeat(path[-1:], len(fractions), axis=0)
    targets = np.asarray(fractions) * arc[-1]
    return np.column_stack([np.interp(targets, arc, path[:, joint])
                            for joint in range(path.shape[1])])


def move_frames(joint_time_s: float, settings: TimingSettings) -> int:
    """Frames of a move that takes `joint_time_s` on the robot (at least one)."""
    seconds = min(joint_time_s * settings.time_scale, settings.max_seconds_per_move)
    return max(1, math.ceil(seconds * settings.fps))


def episode_timeline(record: EpisodeRecord, settings: TimingSettings) -> list[FrameState]:
    """The frame states of the whole episode, in order (holds compressed with `repeat`)."""
    states: list[FrameState] = []

    def hold(joints: np.ndarray, view: int, shown: int, phase: Phase, seconds: float) -> None:
        count = settings.frames(seconds)
        if count > 0:
            states.append(FrameState(joints, view, shown, 1.0, phase, count))

    joints = np.asarray(record.start_joints, dtype=float)
    hold(joints, -1, 0, "start", settings.start_seconds)
    for index, view in enumerate(record.views):
        if view.path is not None and len(view.path) > 1:
            count = move_frames(view.travel.joint_time, settings)
            fractions = np.arange(1, count + 1) / count
            for fraction, q in zip(fractions, along_path(view.path, ease(fractions)), strict=True):
                states.append(FrameState(q, index, index, float(fraction), "move"))
            joints = np.asarray(view.path[-1], dtype=float)
        phase: Phase = "acquire" if view.sensor_pose is not None else "unreachable"
        hold(joints, index, index + 1, phase, settings.hold_seconds)
    hold(joints, len(record.views) - 1, len(record.views), "end", settings.end_seconds)
    return states
