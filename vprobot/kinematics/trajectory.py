"""Timed trajectories and the cycle time: the moves of a plan timed under the robot's velocity,
acceleration and jerk limits, with a stop at every view while the sensor acquires.

A move is a path in joint space: corners joined by straight segments (`waypoints`, (m, dof)),
each segment collision-checked by whoever planned the path. The time law keeps the robot on those
segments, so that their collision check carries over: each segment a -> b is travelled from rest
to rest along its line, q(t) = a + s(t) u with u = (b - a) / max_i |b_i - a_i|, and s(t) is the
time-optimal jerk-limited profile from 0 to max_i |b_i - a_i| that Ruckig computes (one degree of
freedom) under the path's limits v_s = min_i v_i / |u_i|, likewise for acceleration and jerk.
Joint i then moves at |u_i| <= 1 times the path's velocity, acceleration and jerk, within its own
limits, and the leading joint at the path's. Stopping at each corner is slower than blending
through it (TOPP-RA blends, but bounds no jerk); it is what a controller running one `movej` per
segment does.

The cycle of one part: the approach from home to the first view, the moves between views, an
acquisition of `acquisition_time_s` at every view (standing still) and the return to home:
`cycle_time = approach + moves + acquisitions + return`.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import ruckig

from vprobot.robots.description import MotionLimits

JOIN_TOLERANCE_RAD = 1e-9
"""Largest gap between a move's end and the next move's start (and between the return's end and
the approach's start, home)."""
SAMPLE_MERGE_S = 1e-6
"""Corners and acquisition bounds closer in time than this are one instant, sampled once. The
same instant summed in another order (the return's end, and the cycle's total of its parts)
differs by a few ulps, and a controller rejects a trajectory whose times do not strictly
increase (ros2_control's joint_trajectory_controller)."""
MAX_SAMPLES = 1_000_000
"""Most samples of a sampled trajectory (a 2.2-hour cycle at 125 Hz): more would take gigabytes,
in the arrays and more so in an exported file."""


@dataclasses.dataclass(frozen=True)
class Segment:
    """One straight segment of a move, timed from rest to rest.

    Attributes:
        start_s: When it starts, from the start of the cycle.
        start: Its first configuration (rad).
        end: Its last configuration, the corner it stops at (rad).
        direction: Unit step along the segment (largest component 1), rad per unit of `length`.
        length: Travel of the leading joint, max_i |b_i - a_i| (rad).
        profile: Ruckig's one-degree-of-freedom profile of the travel s(t), 0 to `length`.
    """

    start_s: float
    start: np.ndarray
    end: np.ndarray
    direction: np.ndarray
    length: float
    profile: ruckig.Trajectory

    @property
    def duration_s(self) -> float:
        return float(self.profile.duration)

    @property
    def end_s(self) -> float:
        """When it ends, from the start of the cycle."""
        return self.start_s + self.duration_s

    def states(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations (k, dof) at `times` (k,) from the start of
        the cycle, none before the segment's start; at rest at its end from `end_s` on."""
        local = np.clip(times - self.start_s, 0.0, self.duration_s)
        profile = np.array([self.profile.at_time(t) for t in local]).reshape(len(local), 3)
        # Rest to rest: exactly still, and exactly at the corner, once the profile is done
        # (from `end_s`, the very time the plan's bounds hold: `times - start_s` may round
        # below the duration there).
        done = times >= self.end_s
        profile[done] = [self.length, 0.0, 0.0]
        s, ds, dds = (profile[:, [column]] for column in range(3))
        positions = self.start + s * self.direction
        positions[done] = self.end
        return positions, ds * self.direction, dds * self.direction


@dataclasses.dataclass(frozen=True)
class Acquisition:
    """The stop at one view: the robot stands at `position` from `start_s` to `end_s`."""

    start_s: float
    end_s: float
    view: int
    position: np.ndarray


@dataclasses.dataclass(frozen=True)
class CycleTime:
    """The cycle time of one part and its parts (s)."""

    approach_s: float
    moves_s: float
    acquisitions_s: float
    return_s: float

    @property
    def total_s(self) -> float:
        return self.approach_s + self.moves_s + self.acquisitions_s + self.return_s

    def as_dict(self) -> dict[str, float]:
        """The parts and `total_s`, for records."""
        return {**dataclasses.asdict(self), "total_s": self.total_s}


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A timed trajectory sampled for export: states at increasing times.

    Attributes:
        times: (n,) seconds from the start of the cycle, strictly increasing, consecutive ones
            at least min(dt / 2, `SAMPLE_MERGE_S`) apart; every corner and every start and end
            of an acquisition is among them (within `SAMPLE_MERGE_S`).
        positions: (n, dof) joint positions (rad).
        velocities: (n, dof) joint velocities (rad/s).
        accelerations: (n, dof) joint accelerations (rad/s^2).
        joint_names: The joints, in column order.
        acquisitions: (start_s, end_s, view index) of each stop to acquire, at sample times.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray
    joint_names: tuple[str, ...]
    acquisitions: tuple[tuple[float, float, int], ...]


@dataclasses.dataclass(frozen=True)
class TimedMove:
    """One move timed (`time_move`): its corners and its straight segments, on the move's own
    clock (the first segment starts at 0 s).

    Attributes:
        waypoints: The corners (m, dof), m >= 2.
        segments: The segments that have a length, in order.
    """

    waypoints: np.ndarray
    segments: tuple[Segment, ...]

    @property
    def duration_s(self) -> float:
        """How long the move takes, stopping at each corner."""
        return float(sum(segment.duration_s for segment in self.segments))


@dataclasses.dataclass(frozen=True)
class TimedPlan:
    """A plan's moves timed, with its acquisitions: the exact trajectory, to sample or query.

    Attributes:
        segments: The straight segments in order of time, on the cycle's clock; between two of
            them the robot is at rest (at a corner or acquiring).
        acquisitions: The stops at the views, in view order.
        cycle: The cycle time and its parts.
        joint_names: The joints.
        moves: The moves as they were timed (approach, moves between views, return), each on
            its own clock.
    """

    segments: tuple[Segment, ...]
    acquisitions: tuple[Acquisition, ...]
    cycle: CycleTime
    joint_names: tuple[str, ...]
    moves: tuple[TimedMove, ...] = ()

    @property
    def duration_s(self) -> float:
        return self.cycle.total_s

    def states(self, times: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations (k, dof) at `times` (k,), clamped to the cycle.

        Raises:
            ValueError: If the plan has no motion.
        """
        if not self.segments:
            raise ValueError("the plan has no motion to follow")
        times = np.atleast_1d(np.asarray(times, dtype=float))
        # Each time belongs to the last segment started by then; past its end the robot rests
        # at its last corner (at a corner, or acquiring) until the next one starts.
        owner = np.searchsorted([segment.start_s for segment in self.segments], times,
                                side="right") - 1
        owner = np.maximum(owner, 0)
        shape = (len(times), len(self.joint_names))
        positions, velocities, accelerations = np.empty(shape), np.zeros(shape), np.zeros(shape)
        for index, segment in enumerate(self.segments):
            mine = owner == index
            if mine.any():
                positions[mine], velocities[mine], accelerations[mine] = segment.states(
                    times[mine])
        return positions, velocities, accelerations

    def sample(self, dt: float) -> Trajectory:
        """The trajectory at every multiple of `dt` and at every corner and acquisition bound.

        Grid times closer than dt / 2 to such a bound are left out, so that no step is shorter
        than dt / 2 and finite differences of the samples stay well conditioned; bounds less
        than `SAMPLE_MERGE_S` apart are one instant, sampled once (`distinct_times`).

        Raises:
            ValueError: If `dt` is not positive, the trajectory would take more than
                `MAX_SAMPLES` samples, or the plan has no motion.
        """
        if not dt > 0:
            raise ValueError(f"the sampling step must be > 0 s, got {dt!r}")
        count = self.duration_s / dt
        if count > MAX_SAMPLES:  # before any allocation
            raise ValueError(f"sampling the {self.duration_s:.6g} s cycle every {dt:g} s takes "
                             f"{count:.3g} samples, more than {MAX_SAMPLES:,}: sample it more "
                             f"coarsely")
        bounds = distinct_times(np.unique([
            0.0, self.duration_s, *(s.start_s for s in self.segments),
            *(s.end_s for s in self.segments),
            *(t for a in self.acquisitions for t in (a.start_s, a.end_s))]))
        grid = np.arange(0.0, self.duration_s, dt)
        nearest = np.abs(grid[:, None] - bounds[None, :]).min(axis=1)
        times = np.union1d(grid[nearest >= dt / 2], bounds)
        positions, velocities, accelerations = self.states(times)

        def instant(time_s: float) -> float:
            """The bound sampled for `time_s`: the first one kept at or after it."""
            return float(bounds[np.searchsorted(bounds, time_s)])

        return Trajectory(times, positions, velocities, accelerations, self.joint_names,
                          tuple((instant(a.start_s), instant(a.end_s), a.view)
                                for a in self.acquisitions))


def distinct_times(times: np.ndarray) -> np.ndarray:
    """Sorted `times` without those closer than `SAMPLE_MERGE_S` before the next one kept. The
    latest of an instant's times is kept: past a segment's end the robot is exactly at rest at
    its corner, and the cycle ends at its total."""
    kept = [float(times[-1])]
    for time_s in times[-2::-1]:
        if kept[-1] - time_s >= SAMPLE_MERGE_S:
            kept.append(float(time_s))
    return np.array(kept[::-1])


def time_segment(start: npt.ArrayLike, end: npt.ArrayLike, limits: MotionLimits,
                 start_s: float = 0.0) -> Segment | None:
    """Time one straight segment from rest to rest; None when it has no length.

    Raises:
        ValueError: If Ruckig finds no profile (limits not positive and finite).
    """
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    step = end - start
    length = float(np.max(np.abs(step)))
    if length == 0.0:
        return None
    direction = step / length
    moving = direction != 0.0
    share = np.abs(direction[moving])
    otg, request = ruckig.Ruckig(1), ruckig.InputParameter(1)
    request.current_position, request.target_position = [0.0], [length]
    request.max_velocity = [float(np.min(limits.velocity[moving] / share))]
    request.max_acceleration = [float(np.min(limits.acceleration[moving] / share))]
    request.max_jerk = [float(np.min(limits.jerk[moving] / share))]
    profile = ruckig.Trajectory(1)
    try:
        result = otg.calculate(request, profile)
        failure = None if result == ruckig.Result.Working else result.name
    except ruckig.RuckigError as error:  # raised, not returned, for limits it cannot take
        failure = str(error).strip().splitlines()[0]
    if failure is not None:
        raise ValueError(f"Ruckig found no profile for the segment {start.tolist()} -> "
                         f"{end.tolist()} under the path's limits v={request.max_velocity[0]:g}, "
                         f"a={request.max_acceleration[0]:g}, j={request.max_jerk[0]:g} "
                         f"({failure})")
    return Segment(start_s, start, end, direction, length, profile)


def time_move(waypoints: npt.ArrayLike, limits: MotionLimits) -> TimedMove:
    """Time one move along its corners (m, dof), stopping at each: the time law of a move, the
    one function every move's duration comes from (docs/motion.md#the-time-law).

    Raises:
        ValueError: If Ruckig finds no profile for a segment (`time_segment`).
    """
    corners = np.asarray(waypoints, dtype=float)
    segments: list[Segment] = []
    clock = 0.0
    for start, end in itertools.pairwise(corners):
        segment = time_segment(start, end, limits, clock)
        if segment is not None:
            segments.append(segment)
            clock = segment.end_s
    return TimedMove(corners, tuple(segments))


def chain_moves(moves: Sequence[TimedMove], acquisition_time_s: float,
                joint_names: Sequence[str]) -> TimedPlan:
    """The cycle of timed moves, each starting where the one before ends: the approach, the
    moves between views and the return, with a stop of `acquisition_time_s` at every view.

    The moves are timed already (`time_move`); this only puts them on the cycle's clock, so a
    cycle costs no more timing than its moves did. The checks are `time_plan`'s (an episode's
    moves join by construction).
    """
    segments: list[Segment] = []
    acquisitions: list[Acquisition] = []
    durations = []
    clock = 0.0
    for index, move in enumerate(moves):
        started = clock
        for segment in move.segments:
            segments.append(dataclasses.replace(segment, start_s=clock))
            clock = segments[-1].end_s
        durations.append(clock - started)
        if index < len(moves) - 1:
            acquisitions.append(Acquisition(clock, clock + acquisition_time_s, index,
                                            move.waypoints[-1]))
            clock += acquisition_time_s
    cycle = (CycleTime(durations[0], sum(durations[1:-1]), acquisition_time_s * len(acquisitions),
                       durations[-1]) if moves else CycleTime(0.0, 0.0, 0.0, 0.0))
    return TimedPlan(tuple(segments), tuple(acquisitions), cycle, tuple(joint_names),
                     tuple(moves))


def time_plan(moves: Sequence[npt.ArrayLike], limits: MotionLimits, acquisition_time_s: float,
              joint_names: Sequence[str]) -> TimedPlan:
    """Time a plan's moves: approach, the moves between views, return; a stop at every view.

    Args:
        moves: The approach (home to the first view), the moves between consecutive views and
            the return (last view to home), each a (m, dof) array of corners, m >= 2, joined by
            straight segments; each starts where the one before ends. An empty sequence is a
            plan without views (cycle time 0).
        limits: The robot's motion limits.
        acquisition_time_s: How long the robot stands at each view while the sensor acquires.
        joint_names: The joints, in column order.

    Raises:
        ValueError: If a move is not a (m >= 2, dof) array of finite values, a move does not
            start where the one before ends, the return does not end at the approach's start,
            there is a single move, the acquisition time is negative, or the joint names do not
            match the limits.
    """
    if not 0.0 <= acquisition_time_s < math.inf:
        raise ValueError(f"acquisition_time_s must be >= 0 s (finite), got {acquisition_time_s!r}")
    if len(joint_names) != limits.dof:
        raise ValueError(f"{len(joint_names)} joint names for {limits.dof} joints")
    paths = [_waypoints(move, limits.dof, index) for index, move in enumerate(moves)]
    if len(paths) == 1:
        raise ValueError("a plan's moves are an approach, moves between views and a return: "
                         "at least 2, got 1")
    for index, path in enumerate(paths):
        following = paths[(index + 1) % len(paths)]
        if np.max(np.abs(following[0] - path[-1])) > JOIN_TOLERANCE_RAD:
            what = ("the return must end where the approach starts (home)"
                    if index == len(paths) - 1 else f"move {index + 1} must start where move "
                    f"{index} ends")
            raise ValueError(f"{what}: {path[-1].tolist()} vs {following[0].tolist()}")
    return chain_moves([time_move(path, limits) for path in paths], acquisition_time_s,
                       joint_names)


def _waypoints(move: npt.ArrayLike, dof: int, index: int) -> np.ndarray:
    path = np.asarray(move, dtype=float)
    if path.ndim != 2 or path.shape[0] < 2 or path.shape[1] != dof:
        raise ValueError(f"move {index} must be a (m >= 2, {dof}) array of corners, got shape "
                         f"{path.shape}")
    if not np.all(np.isfinite(path)):
        raise ValueError(f"move {index} has non-finite corners")
    return path
