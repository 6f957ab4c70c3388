"""Timed trajectories and the cycle time (`vprobot.kinematics.trajectory`).

The limits are checked by finite differences on the samples, not by Ruckig's word, and the
duration of a move against the closed-form time-optimal jerk-limited (7-segment) profile.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from vprobot.kinematics.trajectory import (
    MotionLimits,
    TimedPlan,
    Trajectory,
    time_plan,
    time_segment,
)
from vprobot.robots import load_robot

ROBOTS = ("ur5", "ur10", "panda")


def seven_segment_duration(distance: float, v: float, a: float, j: float) -> float:
    """Duration of the time-optimal rest-to-rest move over `distance` under velocity,
    acceleration and jerk limits: the textbook double-S profile (Biagiotti & Melchiorri,
    "Trajectory Planning for Automatic Machines and Robots", sec. 3.4), written out here as the
    independent reference."""
    if v * j >= a * a:  # the acceleration limit is reached on the way to full speed
        ramp, hold = a / j, v / a - a / j
    else:
        ramp, hold = math.sqrt(v / j), 0.0
    accelerating = 2 * ramp + hold
    if distance >= v * accelerating:  # full speed is reached: cruise the rest
        return 2 * accelerating + (distance - v * accelerating) / v
    if distance >= 2 * a**3 / j**2:  # no cruise, the acceleration limit still reached
        ramp = a / j
        hold = (-3 * ramp + math.sqrt(ramp**2 + 4 * distance / a)) / 2
        return 4 * ramp + 2 * hold
    return 4 * (distance / (2 * j)) ** (1 / 3)


def derivatives(trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Velocity, acceleration and jerk as divided differences of the sampled positions (times
    1!, 2!, 3!): each is a weighted mean of the true derivative over its stencil, so it never
    exceeds the true derivative's largest magnitude."""
    t, q = trajectory.times[:, None], trajectory.positions
    velocity = np.diff(q, axis=0) / np.diff(t, axis=0)
    acceleration = 2 * np.diff(velocity, axis=0) / (t[2:] - t[:-2])
    jerk = 3 * np.diff(acceleration, axis=0) / (t[3:] - t[:-3])
    return velocity, acceleration, jerk


def random_plan(robot: str, views: int, corners: int, seed: int) -> tuple[list[np.ndarray],
                                                                          MotionLimits]:
    """Moves home -> views -> home, each through `corners` random intermediate corners."""
    description = load_robot(robot)
    rng = np.random.default_rng(seed)
    home = np.array(description.home)
    stops = [home, *(home + rng.uniform(-1.0, 1.0, len(home)) for _ in range(views)), home]
    moves = []
    for start, end in itertools.pairwise(stops):
        middle = [start + rng.uniform(0, 1) * (end - start) + rng.normal(0, 0.3, len(home))
                  for _ in range(corners)]
        moves.append(np.array([start, *middle, end]))
    return moves, MotionLimits.of(description)


def timed(moves: list[np.ndarray], limits: MotionLimits, acquisition_s: float = 0.5) -> TimedPlan:
    return time_plan(moves, limits, acquisition_s, [f"j{i}" for i in range(limits.dof)])


@pytest.mark.parametrize("robot", ROBOTS)
def test_limits_hold_by_finite_differences_for_every_bundled_robot(robot: str) -> None:
    moves, limits = random_plan(robot, views=3, corners=2, seed=1)
    trajectory = timed(moves, limits).sample(1e-3)
    velocity, acceleration, jerk = derivatives(trajectory)
    for values, limit in ((velocity, limits.velocity), (acceleration, limits.acceleration),
                          (jerk, limits.jerk)):
        ratio = np.max(np.abs(values), axis=0) / limit
        assert np.all(ratio <= 1 + 1e-6), ratio
        # Time-optimal segments drive some joint to its velocity or acceleration limit.
        assert ratio.max() > 0.5
    # The sampled velocities and accelerations are the trajectory's own, within the limits too.
    assert np.all(np.abs(trajectory.velocities) <= limits.velocity * (1 + 1e-9))
    assert np.all(np.abs(trajectory.accelerations) <= limits.acceleration * (1 + 1e-9))


def test_the_robot_stays_on_each_straight_segment() -> None:
    moves, limits = random_plan("ur10", views=3, corners=3, seed=2)
    plan = timed(moves, limits)
    trajectory = plan.sample(2e-3)
    corners = [pair for move in moves for pair in itertools.pairwise(move)]
    assert len(plan.segments) == len(corners)
    for segment, (a, b) in zip(plan.segments, corners, strict=True):
        inside = ((trajectory.times >= segment.start_s)
                  & (trajectory.times <= segment.start_s + segment.duration_s))
        offsets = trajectory.positions[inside] - a
        along = offsets @ (b - a) / ((b - a) @ (b - a))
        off_line = offsets - along[:, None] * (b - a)
        assert inside.sum() > 10
        assert np.max(np.linalg.norm(off_line, axis=1)) < 1e-12
        assert along.min() >= -1e-12 and along.max() <= 1 + 1e-12


def test_every_corner_is_reached_exactly_and_at_rest() -> None:
    moves, limits = random_plan("panda", views=2, corners=2, seed=3)
    plan = timed(moves, limits)
    corners = [corner for move in moves for corner in move[1:]]
    for segment, corner in zip(plan.segments, corners, strict=True):
        (position,), (velocity,), (acceleration,) = plan.states(
            segment.start_s + segment.duration_s)
        np.testing.assert_array_equal(position, corner)
        np.testing.assert_array_equal(velocity, 0)
        np.testing.assert_array_equal(acceleration, 0)
    trajectory = plan.sample(0.01)
    np.testing.assert_allclose(trajectory.positions[0], moves[0][0], atol=1e-9)
    np.testing.assert_allclose(trajectory.positions[-1], moves[-1][-1], atol=1e-9)
    assert trajectory.times[-1] == pytest.approx(plan.cycle.total_s, abs=1e-12)


@pytest.mark.parametrize(("distance", "v", "a", "j"), [
    (2.0, 2.16, 5.0, 100.0),   # UR10 shoulder: cruise at full speed
    (0.5, 2.16, 5.0, 100.0),   # acceleration limit reached, no cruise
    (0.002, 2.16, 5.0, 100.0),  # neither acceleration nor velocity limit reached
    (1.0, 2.175, 15.0, 7500.0),  # Panda joint 1
    (3.0, 1.0, 10.0, 50.0),    # velocity reached before the acceleration limit (v j < a^2)
])
def test_a_single_joint_move_takes_the_closed_form_time_optimal_duration(
        distance: float, v: float, a: float, j: float) -> None:
    limits = MotionLimits(np.array([v, 9.0, 9.0]), np.array([a, 1.0, 1.0]),
                          np.array([j, 1.0, 1.0]))
    start = np.array([0.3, -0.2, 0.1])
    segment = time_segment(start, start + [distance, 0.0, 0.0], limits)
    assert segment.duration_s == pytest.approx(seven_segment_duration(distance, v, a, j),
                                               rel=1e-9)


@pytest.mark.parametrize("scale", [1.0, 0.5, 0.2])
def test_a_speed_scale_times_the_same_move_one_over_the_scale_slower(scale: float) -> None:
    # cell.safety.speed_scale s: velocity times s, acceleration s^2, jerk s^3 (`scaled`); the
    # double-S profile's duration under those limits is the unscaled one over s.
    robot = MotionLimits(np.array([2.094, 9.0]), np.array([5.0, 9.0]), np.array([100.0, 9.0]))
    segment = time_segment([0.0, 0.0], [1.2, 0.0], robot.scaled(scale))
    assert segment.duration_s == pytest.approx(
        seven_segment_duration(1.2, 2.094 * scale, 5.0 * scale**2, 100.0 * scale**3), rel=1e-9)
    assert segment.duration_s == pytest.approx(
        seven_segment_duration(1.2, 2.094, 5.0, 100.0) / scale, rel=1e-9)


def test_a_diagonal_move_is_as_fast_as_its_tightest_joint_allows() -> None:
    # Joint 0 travels 1 rad, joint 1 travels 0.5 rad: along the line joint 1's limits count at
    # twice their size, so the path's limits are v = min(1, 2 * 3) = 1, a = min(10, 2 * 2) = 4,
    # j = min(100, 2 * 30) = 60.
    limits = MotionLimits(np.array([1.0, 3.0]), np.array([10.0, 2.0]), np.array([100.0, 30.0]))
    segment = time_segment([0.0, 0.0], [1.0, -0.5], limits)
    assert segment.duration_s == pytest.approx(seven_segment_duration(1.0, 1.0, 4.0, 60.0),
                                               rel=1e-9)


def test_cycle_time_is_the_sum_of_its_parts() -> None:
    moves, limits = random_plan("ur10", views=4, corners=1, seed=4)
    plan = timed(moves, limits, acquisition_s=0.7)
    cycle = plan.cycle
    by_move = np.add.reduceat([s.duration_s for s in plan.segments], [0, 2, 4, 6, 8])
    assert cycle.approach_s == pytest.approx(by_move[0], rel=1e-12)
    assert cycle.moves_s == pytest.approx(by_move[1:-1].sum(), rel=1e-12)
    assert cycle.return_s == pytest.approx(by_move[-1], rel=1e-12)
    assert cycle.acquisitions_s == pytest.approx(4 * 0.7)
    assert cycle.total_s == pytest.approx(
        cycle.approach_s + cycle.moves_s + cycle.acquisitions_s + cycle.return_s, rel=1e-12)
    assert cycle.as_dict()["total_s"] == cycle.total_s
    last = plan.segments[-1]
    assert last.start_s + last.duration_s == pytest.approx(cycle.total_s, rel=1e-12)


def test_the_robot_stands_still_at_each_view_for_the_acquisition_time() -> None:
    moves, limits = random_plan("ur5", views=3, corners=1, seed=5)
    plan = timed(moves, limits, acquisition_s=0.4)
    trajectory = plan.sample(0.01)
    assert [view for _, _, view in trajectory.acquisitions] == [0, 1, 2]
    for (start, end, view), acquisition in zip(trajectory.acquisitions, plan.acquisitions,
                                               strict=True):
        assert end - start == pytest.approx(0.4)
        during = (trajectory.times >= start) & (trajectory.times <= end)
        assert during.sum() >= 40
        np.testing.assert_allclose(trajectory.positions[during], np.broadcast_to(
            moves[view][-1], (during.sum(), limits.dof)), atol=1e-9)
        assert np.all(trajectory.velocities[during] == 0)
        assert np.all(trajectory.accelerations[during] == 0)
        np.testing.assert_allclose(acquisition.position, moves[view + 1][0], atol=1e-9)


def test_a_plan_without_views_takes_no_time() -> None:
    plan = timed([], MotionLimits.of(load_robot("ur10")))
    assert plan.cycle.total_s == 0.0 and plan.segments == () and plan.acquisitions == ()


@pytest.mark.parametrize(("change", "message"), [
    (lambda moves: moves[:1], r"at least 2, got 1"),
    (lambda moves: [moves[0], moves[1][:, :5], moves[2]],
     r"move 1 must be a \(m >= 2, 6\) array of corners, got shape \(2, 5\)"),
    (lambda moves: [moves[0], moves[1][:1], moves[2]], r"move 1 must be a \(m >= 2, 6\)"),
    (lambda moves: [moves[0], moves[1] + 0.01, moves[2]], r"move 1 must start where move 0 ends"),
    (lambda moves: [moves[0], moves[1], moves[2][:, :] + [[0] * 6, [0.1] * 6]],
     r"the return must end where the approach starts \(home\)"),
    (lambda moves: [moves[0], np.full((2, 6), np.nan), moves[2]], r"move 1 has non-finite"),
])
def test_bad_moves_are_named(change: object, message: str) -> None:
    moves, limits = random_plan("ur10", views=2, corners=0, seed=6)
    with pytest.raises(ValueError, match=message):
        timed(change(moves), limits)


def test_bad_acquisition_time_and_sampling_step_are_named() -> None:
    moves, limits = random_plan("ur10", views=2, corners=0, seed=7)
    with pytest.raises(ValueError, match=r"acquisition_time_s must be >= 0 s \(finite\), got -1"):
        timed(moves, limits, acquisition_s=-1.0)
    with pytest.raises(ValueError, match=r"sampling step must be > 0 s, got 0"):
        timed(moves, limits).sample(0)


def test_bounds_a_few_ulps_apart_are_sampled_once() -> None:
    from vprobot.kinematics.trajectory import SAMPLE_MERGE_S

    # As in the realistic-cell B_SCP plan of issue 42 (15 s to plan, so built here): the same
    # instant summed in another order, ulps apart; here every acquisition's start and end
    # (1e-15 s later) and the cycle's end (two ulps of it later).
    moves, limits = random_plan("ur10", views=3, corners=1, seed=8)
    plan = timed(moves, limits)
    later = 2 * np.spacing(plan.cycle.total_s)
    plan = dataclasses.replace(
        plan, cycle=dataclasses.replace(plan.cycle, return_s=plan.cycle.return_s + later),
        acquisitions=tuple(dataclasses.replace(a, start_s=a.start_s + 1e-15,
                                               end_s=a.end_s + 1e-15) for a in plan.acquisitions))
    # The approach's last segment ends a few ulps before the first acquisition starts.
    assert 0 < plan.acquisitions[0].start_s - plan.segments[1].end_s < 1e-14
    assert 0 < plan.cycle.total_s - plan.segments[-1].end_s < 1e-14
    trajectory = plan.sample(0.01)
    assert np.diff(trajectory.times).min() >= SAMPLE_MERGE_S
    # Each acquisition is a stretch of samples at its view's corner, starting and ending on one.
    for (start, end, view), acquisition in zip(trajectory.acquisitions, plan.acquisitions,
                                               strict=True):
        assert start in trajectory.times and end in trajectory.times
        assert abs(start - acquisition.start_s) < SAMPLE_MERGE_S
        during = (trajectory.times >= start) & (trajectory.times <= end)
        np.testing.assert_array_equal(trajectory.positions[during],
                                      np.broadcast_to(moves[view][-1], (during.sum(), 6)))
    assert trajectory.times[-1] == pytest.approx(plan.cycle.total_s, abs=SAMPLE_MERGE_S)
    np.testing.assert_array_equal(trajectory.positions[-1], moves[-1][-1])


def test_a_step_that_takes_too_many_samples_is_refused_before_sampling() -> None:
    from vprobot.kinematics.trajectory import MAX_SAMPLES

    moves, limits = random_plan("ur10", views=2, corners=0, seed=9)
    with pytest.raises(ValueError, match=f"more than {MAX_SAMPLES:,}: sample it more coarsely"):
        timed(moves, limits).sample(1e-12)  # 10^13 samples, 80 TB of times alone


@pytest.mark.parametrize("velocity", [0.0, 1e-300])
def test_limits_ruckig_cannot_take_are_a_value_error(velocity: float) -> None:
    limits = MotionLimits(np.array([velocity, 1.0]), np.ones(2), np.ones(2))
    with pytest.raises(ValueError, match=r"Ruckig found no profile .* under the path's limits"):
        time_segment([0.0, 0.0], [1.0, 0.5], limits)
