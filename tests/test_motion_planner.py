"""Collision-free moves: the straight line when free, else OMPL's RRT-Connect, checked densely."""

from __future__ import annotations

import dataclasses
import itertools
import time

import numpy as np
import pytest

from vprobot.cell.scene import Cell
from vprobot.config import CellConfig, Config, ConfigError, KinematicsConfig, replace
from vprobot.episode import Episode, PartScene
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.kinematics.collision import CollisionChecker
from vprobot.kinematics.motion_planner import SEARCHES, MotionPlanner, densify
from vprobot.kinematics.path import joint_path
from vprobot.kinematics.travel import joint_time

Q_FROM = np.array([0.9, -0.5, 2.1, -3.1, -0.8, -2.6])
Q_TO = Q_FROM * [-1, 1, 1, 1, 1, 1]
"""A move of the UR10 (default cell) whose straight line sweeps the sensor through the fixture."""

FINE_STEP_RAD = 0.01
"""The independent check samples five times finer than the planner's 0.05 rad."""


def make_arm(**kinematics: object) -> RobotArm:
    config = dataclasses.replace(
        Config(), cell=dataclasses.replace(CellConfig(), robot="ur10"),
        kinematics=dataclasses.replace(KinematicsConfig(), **kinematics))
    return RobotArm(Cell(config))


@pytest.fixture(scope="module")
def arm() -> RobotArm:
    return make_arm()


def planner(arm: RobotArm, **kinematics: object) -> MotionPlanner:
    return MotionPlanner(arm.collisions, arm.joints,
                         dataclasses.replace(arm.settings, **kinematics))


def collides_anywhere(checker: CollisionChecker, waypoints: np.ndarray) -> bool:
    """Whether any configuration on the segments between `waypoints`, sampled finely, collides."""
    return any(checker.in_collision(q)
               for a, b in itertools.pairwise(waypoints)
               for q in joint_path(a, b, FINE_STEP_RAD))


def test_colliding_line_gets_a_planned_path_that_a_finer_check_finds_free(arm: RobotArm) -> None:
    independent = CollisionChecker(arm.cell)
    assert collides_anywhere(independent, np.array([Q_FROM, Q_TO]))
    plan = planner(arm).plan(Q_FROM, Q_TO)
    assert plan is not None and plan.method == "rrt_connect"
    assert len(plan.waypoints) >= 3
    np.testing.assert_array_equal(plan.waypoints[0], Q_FROM)
    np.testing.assert_array_equal(plan.waypoints[-1], Q_TO)
    assert not collides_anywhere(independent, plan.waypoints)
    assert arm.joints.within_limits(plan.waypoints)
    # The dense path runs through every corner at the configured resolution.
    assert np.max(np.abs(np.diff(plan.path, axis=0))) <= arm.settings.path_max_joint_step_rad
    for corner in plan.waypoints:
        assert np.min(np.max(np.abs(plan.path - corner), axis=1)) == 0.0


def test_free_line_is_exactly_its_two_ends(arm: RobotArm) -> None:
    q_to = arm.joints.start + [0.3, -0.2, 0.1, 0.2, -0.3, 0.4]
    assert not collides_anywhere(CollisionChecker(arm.cell), np.array([arm.joints.start, q_to]))
    plan = planner(arm).plan(arm.joints.start, q_to)
    assert plan is not None and plan.method == "line"
    np.testing.assert_array_equal(plan.waypoints, [arm.joints.start, q_to])
    np.testing.assert_allclose(plan.path, joint_path(arm.joints.start, q_to, 0.05))


def test_same_query_gives_the_same_path_whatever_ran_before(arm: RobotArm) -> None:
    first = planner(arm).plan(Q_FROM, Q_TO)
    reverse = planner(arm).plan(Q_TO, Q_FROM)  # another query in between draws other numbers
    again = make_arm().plan(Q_FROM, Q_TO)
    assert first is not None and reverse is not None and again is not None
    np.testing.assert_array_equal(first.waypoints, again.waypoints)
    assert not np.array_equal(first.waypoints, reverse.waypoints[::-1])


def test_goal_in_collision_has_no_path(arm: RobotArm) -> None:
    fixture_pass = (Q_FROM + Q_TO) / 2  # the sensor inside the fixture
    assert arm.collisions.in_collision(fixture_pass)
    assert planner(arm).plan(Q_FROM, fixture_pass) is None


@pytest.mark.parametrize("budget", [{"path_planning_checks": 10},
                                    {"path_planning_time_s": 1e-9}])
def test_planning_out_of_budget_has_no_path(arm: RobotArm, budget: dict[str, object]) -> None:
    assert planner(arm, **budget).plan(Q_FROM, Q_TO) is None


def test_waiting_for_a_core_does_not_spend_the_time_cap(arm: RobotArm,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A search descheduled for longer than its cap (as on a loaded machine: here a sleep at its
    first check) finds the path of an undisturbed one: the cap counts the planning thread's CPU
    time. A wall-clock cap would have ended it with no path."""
    cap_s = 0.1  # the search needs about 0.02 s of CPU
    undisturbed = planner(arm, path_planning_time_s=cap_s).plan(Q_FROM, Q_TO)
    assert undisturbed is not None and undisturbed.method == "rrt_connect"
    check = arm.collisions.in_collision
    pauses = [cap_s + 0.1]

    def descheduled(q: np.ndarray) -> bool:
        if pauses:
            time.sleep(pauses.pop())
        return check(q)

    monkeypatch.setattr(arm.collisions, "in_collision", descheduled)
    delayed = planner(arm, path_planning_time_s=cap_s).plan(Q_FROM, Q_TO)
    assert not pauses, "the search never checked a state"
    assert delayed is not None and delayed.planning_time_s > cap_s
    np.testing.assert_array_equal(delayed.waypoints, undisturbed.waypoints)


def test_line_planner_does_not_go_around(arm: RobotArm) -> None:
    assert planner(arm, path_planner="line").plan(Q_FROM, Q_TO) is None


class GrazingPlanner(MotionPlanner):
    """Finds the first `rejected` planned paths colliding in the dense check, as a path that
    grazes an obstacle between OMPL's samples would; other checks stay real."""

    def __init__(self, arm: RobotArm, rejected: int):
        super().__init__(arm.collisions, arm.joints, arm.settings)
        self.rejected = rejected
        self.planned: list[np.ndarray] = []

    def is_free(self, path: np.ndarray) -> bool:
        straight = densify(path[[0, -1]], self.settings.path_max_joint_step_rad)
        if len(path) > 2 and (path.shape != straight.shape or not np.array_equal(path, straight)):
            self.planned.append(path)
            if len(self.planned) <= self.rejected:
                return False
        return super().is_free(path)


def test_a_path_failing_the_dense_check_is_searched_for_again(arm: RobotArm) -> None:
    first = planner(arm).plan(Q_FROM, Q_TO)
    grazing = GrazingPlanner(arm, rejected=1)
    again = grazing.plan(Q_FROM, Q_TO)
    assert first is not None and again is not None and len(grazing.planned) == 2
    np.testing.assert_array_equal(grazing.planned[0], first.path)
    assert not np.array_equal(again.waypoints, first.waypoints)
    assert not collides_anywhere(CollisionChecker(arm.cell), again.waypoints)
    assert GrazingPlanner(arm, rejected=SEARCHES).plan(Q_FROM, Q_TO) is None


def test_reach_goes_around_the_fixture_and_reports_the_path() -> None:
    goal = make_arm().fk(Q_TO)
    target = SensorTarget.full_pose(goal.position, goal.quaternion)
    around = make_arm(restarts=0).reach(target, Q_FROM)
    assert around.reachable and around.motion is not None
    assert around.motion.method == "rrt_connect"
    np.testing.assert_array_equal(around.path, around.motion.path)
    line = make_arm(restarts=0, path_planner="line").reach(target, Q_FROM)
    assert not line.reachable and line.reason == "path_not_found" and line.motion is None


def test_travel_adds_up_along_the_waypoints(arm: RobotArm) -> None:
    plan = planner(arm).plan(Q_FROM, Q_TO)
    assert plan is not None
    travel = arm.travel(Q_FROM, Q_TO, arm.cell.object_center, plan)
    velocity = arm.joints.velocity_limits
    by_hand = sum(float(np.max(np.abs(b - a) / velocity))
                  for a, b in zip(plan.waypoints[:-1], plan.waypoints[1:], strict=True))
    assert travel.joint_time == pytest.approx(by_hand)
    assert travel.joint_time > joint_time(Q_FROM, Q_TO, velocity)
    assert travel.joint_path == pytest.approx(float(np.abs(np.diff(plan.waypoints, axis=0)).sum()))
    straight = arm.travel(Q_FROM, Q_TO, arm.cell.object_center)
    assert travel.cartesian > straight.cartesian and travel.paper == straight.paper


def test_driving_around_the_fixture_records_the_waypoints() -> None:
    scene = PartScene.load(Config(), DEFAULT_MOTOR, resolution=(107, 75))
    episode = Episode(scene, np.eye(3), start_joints=Q_FROM)
    q_to = np.array([-1.2, -0.6, 2.1, -2.9, -0.7, -2.5])  # Q_TO's arm would touch the motor
    checker = episode.carrier.collisions
    assert collides_anywhere(checker, np.array([Q_FROM, q_to]))
    view = episode.replay(q_to)
    assert view.reachable and view.waypoints is not None and len(view.waypoints) >= 3
    np.testing.assert_array_equal(view.waypoints[[0, -1]], [Q_FROM, q_to])
    np.testing.assert_array_equal(view.path, episode.carrier.plan(Q_FROM, q_to).path)
    assert not collides_anywhere(checker, view.waypoints)


@pytest.mark.parametrize("changes", [{"path_planning_time_s": 0.0},
                                     {"path_planning_checks": 0},
                                     {"path_planner": "prm"}])
def test_bad_planning_settings_are_refused(changes: dict[str, object]) -> None:
    with pytest.raises(ConfigError, match=next(iter(changes))):
        replace(Config(), "kinematics", **changes)
