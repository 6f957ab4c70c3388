"""Kinematics against independent references: published DH parameters, geometry, hand values."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from dh_reference import world_flange, world_sensor

from vprobot.cell.scene import Cell
from vprobot.config import CellConfig, Config, KinematicsConfig, SensorConfig
from vprobot.files.paths import available_robots
from vprobot.geometry.poses import rotation_angle
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.kinematics.path import joint_path
from vprobot.kinematics.travel import joint_path_length, joint_time, paper_travel


def make_arm(robot: str = "ur10", **kinematics: object) -> RobotArm:
    config = dataclasses.replace(
        Config(),
        cell=dataclasses.replace(CellConfig(), robot=robot),
        kinematics=dataclasses.replace(KinematicsConfig(), **kinematics),
    )
    return RobotArm(Cell(config))


@pytest.fixture(scope="module")
def arm() -> RobotArm:
    return make_arm()


def free_configurations(arm: RobotArm, count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    configurations = []
    while len(configurations) < count:
        q = rng.uniform(-np.pi, np.pi, arm.joints.dof)
        if not arm.collisions.in_collision(q):
            configurations.append(q)
    return configurations


@pytest.mark.parametrize("robot", ["ur5", "ur10", "panda"])
def test_fk_matches_published_dh_parameters(robot: str) -> None:
    # A turned and tilted base and a tilted, offset mount, so that every part of the composition
    # shows. The Panda's reference is Franka's modified DH table, not its URDF or MJCF.
    config = dataclasses.replace(
        Config(),
        cell=dataclasses.replace(CellConfig(), robot=robot, robot_base_position_m=(0.1, -0.2, 0.4),
                                 robot_base_yaw_deg=30.0, robot_base_tilt_deg=20.0),
        sensor=dataclasses.replace(SensorConfig(), mount_position_m=(0.01, -0.02, 0.09),
                                   mount_quaternion_wxyz=(0.9, 0.1, -0.3, 0.2)),
    )
    arm = RobotArm(Cell(config))
    rng = np.random.default_rng(7)
    for _ in range(25):
        q = rng.uniform(arm.joints.lower, arm.joints.upper)
        # Base pose and sensor mount come from the config, not from the compiled model.
        expected_flange, expected_sensor = world_flange(q, config), world_sensor(q, config)
        flange = arm.forward.flange_pose(q)
        np.testing.assert_allclose(flange.position, expected_flange[:3, 3], atol=1e-6)
        np.testing.assert_allclose(flange.rotation, expected_flange[:3, :3], atol=1e-6)
        sensor = arm.fk(q)
        np.testing.assert_allclose(sensor.position, expected_sensor[:3, 3], atol=1e-6)
        np.testing.assert_allclose(sensor.rotation, expected_sensor[:3, :3], atol=1e-6)


def test_ik_round_trip_from_home(arm: RobotArm) -> None:
    converged = 0
    targets = free_configurations(arm, 100, seed=1)
    for q_star in targets:
        goal = arm.fk(q_star)
        result = arm.reach(SensorTarget.full_pose(goal.position, goal.quaternion), arm.joints.start)
        if result.reason in ("did_not_converge", "joint_limits"):
            continue
        converged += 1
        reached = arm.fk(result.q)
        assert np.linalg.norm(reached.position - goal.position) <= 1e-3
        assert np.rad2deg(rotation_angle(reached.rotation, goal.rotation)) <= 0.5
    assert converged >= 99


def test_look_at_axis_passes_through_point(arm: RobotArm) -> None:
    center = arm.cell.object_center
    for direction in ([-1.0, 0.2, 0.3], [0.0, -1.0, 0.5], [0.3, 0.3, 1.0], [-0.5, 0.5, -0.4]):
        direction = np.asarray(direction) / np.linalg.norm(direction)
        target = SensorTarget.look_at(center + 0.47 * direction, center)
        result = arm.reach(target, arm.joints.start)
        assert result.reason not in ("did_not_converge", "joint_limits"), direction
        pose = arm.fk(result.q)
        offset = center - pose.position
        miss = np.linalg.norm(offset - np.dot(offset, pose.view_axis) * pose.view_axis)
        assert miss <= 1e-3
        assert np.dot(offset, pose.view_axis) > 0  # looking at it, not away from it


def test_far_target_is_out_of_reach(arm: RobotArm) -> None:
    base = arm.cell.robot_base.position
    target = SensorTarget.look_at(base + [2.0, 0.0, 0.0], base + [3.0, 0.0, 0.0])
    result = arm.reach(target, arm.joints.start)
    assert not result.reachable
    assert result.reason == "out_of_reach" and result.attempts == 0


def test_target_inside_the_fixture_collides(arm: RobotArm) -> None:
    fixture_top = arm.collisions.data.mocap_pos[arm.cell.fixture_mocap_id]
    inside = fixture_top - [0.0, 0.0, 0.01]
    result = arm.reach(SensorTarget.look_at(inside, inside + [0.0, 0.0, -1.0]), arm.joints.start)
    assert not result.reachable
    assert result.reason == "collision"


def test_path_through_the_fixture_is_not_found_by_the_line_planner() -> None:
    arm = make_arm(restarts=0, path_planner="line")
    q_from = np.array([0.9, -0.5, 2.1, -3.1, -0.8, -2.6])
    q_to = q_from * [-1, 1, 1, 1, 1, 1]
    assert not arm.collisions.in_collision(q_from) and not arm.collisions.in_collision(q_to)
    midway = arm.collisions.colliding_pairs((q_from + q_to) / 2)
    assert midway and all("fixture" in pair for pair in midway)
    goal = arm.fk(q_to)
    result = arm.reach(SensorTarget.full_pose(goal.position, goal.quaternion), q_from)
    assert not result.reachable
    assert result.reason == "path_not_found"


def test_reported_paths_are_collision_free(arm: RobotArm) -> None:
    center = arm.cell.object_center
    target = SensorTarget.look_at(center + [0.0, -0.47, 0.0], center)
    result = arm.reach(target, arm.joints.start)
    assert result.reachable
    np.testing.assert_allclose(result.path[0], arm.joints.start)
    np.testing.assert_allclose(result.path[-1], result.q)
    assert np.max(np.abs(np.diff(result.path, axis=0))) <= 0.05 + 1e-12
    assert not any(arm.collisions.in_collision(q) for q in result.path)


def test_no_success_outside_joint_limits() -> None:
    arm = make_arm()
    narrow = dataclasses.replace(
        arm.joints, lower=arm.joints.lower.copy(), upper=arm.joints.upper.copy()
    )
    narrow.lower[0], narrow.upper[0] = -0.2, 0.2
    arm.joints = arm.cell.joints = arm.ik.cell.joints = narrow
    center = arm.cell.object_center
    # Straight left of the base: only reachable with the pan joint near +pi/2.
    beside = SensorTarget.look_at(arm.cell.robot_base.position + [0.0, 0.7, 0.3],
                                  arm.cell.robot_base.position + [0.0, 1.5, 0.3])
    result = arm.reach(beside, np.clip(arm.joints.start, narrow.lower, narrow.upper))
    assert not result.reachable
    assert result.reason == "joint_limits"
    rng = np.random.default_rng(3)
    for _ in range(30):
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        result = arm.reach(SensorTarget.look_at(center + 0.47 * direction, center),
                           np.clip(arm.joints.start, narrow.lower, narrow.upper))
        if result.reachable:
            assert narrow.within_limits(result.q)
            assert np.all(result.path >= narrow.lower - 1e-9)
            assert np.all(result.path <= narrow.upper + 1e-9)


def test_travel_costs_against_hand_values(arm: RobotArm) -> None:
    q = arm.joints.start
    center = arm.cell.object_center
    still = arm.travel(q, q, center)
    assert still.joint_time == still.joint_path == still.cartesian == still.paper == 0.0
    moved = q + [0.3, 0.0, 0.0, 0.0, 0.0, 0.0]
    forth, back = arm.travel(q, moved, center), arm.travel(moved, q, center)
    assert forth.joint_time == pytest.approx(0.3 / arm.joints.velocity_limits[0])
    assert forth.joint_path == pytest.approx(0.3)
    for name in ("joint_time", "joint_path", "cartesian", "paper"):
        assert getattr(forth, name) == pytest.approx(getattr(back, name))
    # A pan move swings the sensor along a horizontal circle: chord < arc length <= arc bound.
    start, end = arm.fk(q).position, arm.fk(moved).position
    radius = np.linalg.norm((start - arm.shoulder_position)[:2])
    assert np.linalg.norm(end - start) < forth.cartesian <= radius * 0.3 + 1e-6
    assert forth.cartesian == pytest.approx(radius * 0.3, rel=1e-3)


def test_joint_time_is_the_slowest_joint() -> None:
    velocity = np.array([2.0, 1.0, 4.0])
    assert joint_time(np.zeros(3), np.array([1.0, 0.5, -2.0]), velocity) == pytest.approx(0.5)
    assert joint_path_length(np.zeros(3), np.array([1.0, 0.5, -2.0])) == pytest.approx(3.5)


def test_paper_travel_hand_values() -> None:
    center = np.array([1.0, 2.0, 3.0])
    # Equal radii, a quarter turn: the arc r * pi / 2.
    a, b = center + [0.47, 0.0, 0.0], center + [0.0, 0.47, 0.0]
    assert paper_travel(a, b, center) == pytest.approx(0.47 * np.pi / 2)
    # Opposite directions, radii 0.4 and 0.5: half a circle on the smaller sphere plus 0.1, in
    # either direction (the paper computes the larger-to-smaller case "the other way around").
    a, b = center + [0.0, 0.0, 0.4], center + [0.0, 0.0, -0.5]
    assert paper_travel(a, b, center) == pytest.approx(0.4 * np.pi + 0.1)
    assert paper_travel(b, a, center) == pytest.approx(0.4 * np.pi + 0.1)
    # A quarter turn from 0.5 down to 0.3: 0.3 * pi / 2 + 0.2 both ways.
    a, b = center + [0.5, 0.0, 0.0], center + [0.0, 0.3, 0.0]
    assert paper_travel(a, b, center) == pytest.approx(0.3 * np.pi / 2 + 0.2)
    assert paper_travel(b, a, center) == pytest.approx(0.3 * np.pi / 2 + 0.2)
    # Same direction, different radii: only the radius difference.
    assert paper_travel(center + [0.3, 0, 0], center + [0.45, 0, 0], center) == pytest.approx(0.15)


def test_joint_path_resolution() -> None:
    path = joint_path(np.zeros(2), np.array([0.5, -0.12]), 0.1)
    assert len(path) == 6
    assert np.max(np.abs(np.diff(path, axis=0))) <= 0.1 + 1e-12
    with pytest.raises(ValueError, match="max_joint_step_rad"):
        joint_path(np.zeros(2), np.ones(2), 0.0)


@pytest.mark.parametrize(
    ("position", "look_at", "message"),
    [
        ([np.nan, 0.0, 1.0], [0.0, 0.0, 0.0], "finite"),
        ([np.inf, 0.0, 1.0], [0.0, 0.0, 0.0], "finite"),
        ([0.0, 1.0], [0.0, 0.0, 0.0], "shape"),
        ([0.5, 0.0, 1.0], [0.5, 0.0, 1.0], "coincides"),
    ],
)
def test_bad_targets_are_rejected(position: list, look_at: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SensorTarget.look_at(position, look_at)


def test_bad_configurations_are_rejected(arm: RobotArm) -> None:
    target = SensorTarget.look_at(arm.cell.object_center + [0, -0.47, 0], arm.cell.object_center)
    with pytest.raises(ValueError, match="shape"):
        arm.reach(target, np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        arm.fk(np.full(6, np.nan))
    with pytest.raises(ValueError, match="quaternion"):
        SensorTarget.full_pose([0.5, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0])


def test_unknown_robot_is_rejected() -> None:
    bundled = re.escape(", ".join(available_robots()))
    with pytest.raises(ValueError, match=rf"cell\.robot: unknown robot 'kuka': neither a bundled "
                                         rf"robot \({bundled}\) nor a robot folder"):
        Cell(dataclasses.replace(Config(), cell=CellConfig(robot="kuka")))


@pytest.mark.parametrize(("robot", "share"), [("ur10", 0.8), ("panda", 0.75)])
def test_most_of_the_view_sphere_is_reachable_at_the_robots_own_placement(robot: str,
                                                                          share: float) -> None:
    # docs/cell-and-robots.md#the-view-sphere: the default cell reaches >= 80 % of the view
    # sphere, the Panda from its own (ceiling) placement >= 75 % (within the cell's margins).
    # 80 views spread as evenly as the 900 of the documented figures give the Panda's share
    # within about a point (77.5 % against 76.4 %; 150 views: 76.7 %) at about half the cost of
    # 150: the Panda's unreachable views each exhaust motion-planning searches (seconds apiece).
    from vprobot.benchmarks.kinematics import default_cell, view_sphere_survey, view_sphere_targets

    arm = RobotArm(default_cell(Config(), robot))
    survey = view_sphere_survey(arm, view_sphere_targets(arm.cell, 80), progress=False)
    assert survey["fraction"] >= share


@pytest.mark.benchmark
def test_kinematics_benchmark_reports_the_cell_targets() -> None:
    from vprobot.benchmarks.kinematics import run_kinematics_benchmark

    results = run_kinematics_benchmark(Config(), robots=("ur10", "panda"), samples=10,
                                       progress=False)
    assert results["ik_success_rate"] == 1.0
    assert results["view_sphere_reachable"]["ur10"] >= 0.8
    assert results["view_sphere_reachable"]["panda"] >= 0.8
    assert results["ik_reachable_median_ms"] > 0.0
