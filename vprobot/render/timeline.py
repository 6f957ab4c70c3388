"""The frames of an episode video: where the arm is and how far the episode has got, per frame.

Pure bookkeeping, no OpenGL. The video's clock is the cell's: with the robot's timed cycle
(`EpisodeRecord.timed`, docs/motion.md#cycle-time) the arm follows the timed trajectory,
each move's frames spanning its duration under the robot's velocity, acceleration and jerk limits
(times `time_scale`, capped at `max_seconds_per_move`), holds while the acquisition is shown, and
returns home at the end; every frame carries the elapsed cycle time. Without a cycle (a free-flying
sensor, or a robot that found no path home) the arm moves along each view's joint-space path,
eased in and out and timed by the move's joint time, and there is no clock.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np

from vprobot.episode import EpisodeRecord
from vprobot.kinematics.trajectory import TimedPlan

Phase = Literal["start", "move", "acquire", "unreachable", "return", "home", "end"]
"""`return` is the move back to the start after the last view and `home` the hold there (the
timed cycle's end); `end` the hold at the last view of an episode without a cycle."""


@dataclasses.dataclass(frozen=True)
class TimingSettings:
    """How episode time maps to video frames.

    Attributes:
        fps: Video frames per second.
        time_scale: Video seconds per second of the robot's time (1 = real time): of the cell's
            clock (the move's duration under the time law), or without a cycle of the move's
            joint time.
        max_seconds_per_move: Cap on one move's duration in the video (a longer move is shown
            faster; the clock still shows the cell's time).
        hold_seconds: How long each acquisition (or unreachable request) is shown (the clock
            jumps by the sensor's acquisition time).
        start_seconds: Still frames before the first move.
        end_seconds: Still frames after the last view (once back home, with a cycle).
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
        clock_s: The cell's clock: the elapsed cycle time (s); None without a cycle.
    """

    joints: np.ndarray
    view: int
    shown: int
    progress: float
    phase: Phase
    repeat: int = 1
    clock_s: float | None = None


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


def move_frames(robot_s: float, settings: TimingSettings) -> int:
    """Frames of a move that takes `robot_s` on the robot (its duration on the cell's clock, or
    its joint time without one); at least one."""
    seconds = min(robot_s * settings.time_scale, settings.max_seconds_per_move)
    return max(1, math.ceil(seconds * settings.fps))


def timed_move(timed: TimedPlan, start_s: float, end_s: float, view: int, shown: int,
               phase: Phase, settings: TimingSettings) -> list[FrameState]:
    """The frames of the timed cycle's move from `start_s` to `end_s` on the cell's clock: the
    trajectory's positions at evenly spaced times, the last one at its end; none for a move
    that takes no time."""
    duration = end_s - start_s
    if duration <= 0.0:
        return []
    count = move_frames(duration, settings)
    fractions = np.arange(1, count + 1) / count
    times = start_s + fractions * duration
    positions, _, _ = timed.states(times)
    return [FrameState(q, view, shown, float(fraction), phase, clock_s=float(time))
            for q, fraction, time in zip(positions, fractions, times, strict=True)]


def episode_timeline(record: EpisodeRecord, settings: TimingSettings,
                     timed: TimedPlan | None = None) -> list[FrameState]:
    """The frame states of the whole episode, in order (holds compressed with `repeat`).

    Args:
        record: The episode.
        settings: How its time maps to frames.
        timed: The episode's timed cycle (`record.timed`), whose clock the video
            keeps; None for the untimed video (a free-flying sensor, no path home).
    """
    states: list[FrameState] = []
    clock = 0.0  # the timed cycle's; the untimed video shows none

    def hold(joints: np.ndarray, view: int, shown: int, phase: Phase, seconds: float) -> None:
        count = settings.frames(seconds)
        if count > 0:
            states.append(FrameState(joints, view, shown, 1.0, phase, count,
                                     None if timed is None else clock))

    start = np.asarray(record.start_joints, dtype=float)
    joints = start
    hold(joints, -1, 0, "start", settings.start_seconds)
    # The timed cycle stops at each acquired view in turn; the robot stays where a request
    # failed, so the clock does too.
    stops = iter(() if timed is None else timed.acquisitions)
    for index, view in enumerate(record.views):
        if timed is not None and view.acquired:
            stop = next(stops)
            states += timed_move(timed, clock, stop.start_s, index, index, "move", settings)
            joints, clock = stop.position, stop.end_s
        elif timed is None and view.path is not None and len(view.path) > 1:
            count = move_frames(view.travel.joint_time, settings)
            fractions = np.arange(1, count + 1) / count
            for fraction, q in zip(fractions, along_path(view.path, ease(fractions)), strict=True):
                states.append(FrameState(q, index, index, float(fraction), "move"))
            joints = np.asarray(view.path[-1], dtype=float)
        phase: Phase = "acquire" if view.sensor_pose is not None else "unreachable"
        hold(joints, index, index + 1, phase, settings.hold_seconds)
    last, shown = len(record.views) - 1, len(record.views)
    if timed is None:
        hold(joints, last, shown, "end", settings.end_seconds)
        return states
    states += timed_move(timed, clock, timed.duration_s, last, shown, "return", settings)
    clock = timed.duration_s
    hold(start, last, shown, "home", settings.end_seconds)
    return states
