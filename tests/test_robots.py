"""The robot contract: robot folders, their descriptions, URDF import and a 7-joint arm."""

from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from dh_reference import quaternion_matrix, rotation_difference, world_sensor

from vprobot.cell.scene import Cell
from vprobot.cli import main
from vprobot.config import CellConfig, Config, ConfigError, load_config, replace
from vprobot.env.inspect_env import InspectEnv
from vprobot.files.paths import DEFAULT_MOTOR, ROBOTS_DIR
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.render import episode_from_plan
from vprobot.robots import load_robot

ROBOT_DATA = Path(str(importlib.metadata.distribution("example-robot-data").locate_file(
    "cmeel.prefix/share/example-robot-data/robots")))
UR5_URDF = ROBOT_DATA / "ur_description" / "urdf" / "ur5_robot.urdf"


def cell_of(robot: str | Path, **cell: object) -> Cell:
    return Cell(Config(cell=CellConfig(robot=str(robot), **cell)))


def test_importing_the_ur5_urdf_reproduces_the_committed_ur5(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture) -> None:
    committed = load_robot("ur5")
    out = tmp_path / "my_ur5"
    code = main(["robots", "import", str(UR5_URDF), "--flange", "tool0", "--name", "my_ur5",
                 "--out", str(out), "--home", *map(str, committed.home)])
    assert code == 0, capsys.readouterr().err
    imported = load_robot(str(out))
    assert (imported.base, imported.flange, imported.pan_joint, imported.roll_joint) == (
        committed.base, committed.flange, committed.pan_joint, committed.roll_joint)
    # The import takes the URDF's speeds; the committed UR5 carries the maker's lower ones.
    assert imported.velocity_limits_rad_s == (3.15, 3.15, 3.15, 3.2, 3.2, 3.2)
    # A URDF has no acceleration or jerk limits: the import writes the assumption the UR5 has.
    assert imported.acceleration_limits_rad_s2 == committed.acceleration_limits_rad_s2
    assert imported.jerk_limits_rad_s3 == committed.jerk_limits_rad_s3
    assert "# ASSUMPTION, not a maker's figure" in (out / "robot.yaml").read_text()
    placement = {"robot_base_position_m": (0.1, 0.2, 0.4), "robot_base_yaw_deg": 25.0}
    ours, theirs = cell_of("ur5", **placement), cell_of(out, **placement)
    assert ours.joints.names == theirs.joints.names
    np.testing.assert_array_equal(ours.joints.lower, theirs.joints.lower)
    np.testing.assert_array_equal(ours.joints.upper, theirs.joints.upper)
    arm_ours, arm_theirs = RobotArm(ours), RobotArm(theirs)
    rng = np.random.default_rng(3)
    for _ in range(30):
        q = rng.uniform(ours.joints.lower, ours.joints.upper)
        a, b = arm_ours.fk(q), arm_theirs.fk(q)
        np.testing.assert_allclose(a.position, b.position, atol=1e-12)
        np.testing.assert_allclose(a.rotation, b.rotation, atol=1e-12)
        assert arm_ours.collisions.in_collision(q) == arm_theirs.collisions.in_collision(q)
    assert sorted(p.name for p in (out / "meshes").iterdir()) == sorted(
        p.name for p in (ROBOTS_DIR / "ur5" / "meshes").iterdir())


def test_import_errors_name_the_problem(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    def error(*argv: str) -> str:
        assert main(["robots", "import", *argv]) == 2
        return capsys.readouterr().err

    base = [str(UR5_URDF), "--name", "x", "--out", str(tmp_path / "x")]
    assert "flange link 'tool9' is not in" in error(*base, "--flange", "tool9")
    assert "its links: base_link, shoulder_link" in error(*base, "--flange", "tool9")
    # A chain of three revolute joints is no arm vprobot can use.
    assert "has 3 revolute joints; vprobot supports arms with 6 or 7" in error(
        *base, "--flange", "forearm_link")
    assert "home [0.0] must have 6 values" in error(*base, "--flange", "tool0", "--home", "0")
    copied = tmp_path / "ur5.urdf"
    shutil.copy(UR5_URDF, copied)
    message = error(str(copied), "--flange", "tool0", "--name", "y", "--out",
                    str(tmp_path / "y"))
    assert "package 'example-robot-data' not found" in message and "--package" in message
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()
    assert list(tmp_path.iterdir()) == [copied]  # nothing half-written left behind
    code = main(["robots", "import", str(copied), "--flange", "tool0", "--name", "y", "--out",
                 str(tmp_path / "y"), "--package", f"example-robot-data={ROBOT_DATA.parent}"])
    assert code == 0 and load_robot(str(tmp_path / "y")).dof == 6
    assert "exists" in error(str(copied), "--flange", "tool0", "--name", "y", "--out",
                             str(tmp_path / "y"))


def test_a_joint_without_a_child_link_is_a_user_error(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    urdf = tmp_path / "broken.urdf"
    urdf.write_text('<robot name="r"><link name="a"/><link name="b"/>'
                    '<joint name="j" type="revolute"><parent link="a"/></joint></robot>')
    assert main(["robots", "import", str(urdf), "--flange", "b", "--name", "r", "--out",
                 str(tmp_path / "r")]) == 2
    assert f"joint 'j' of {urdf} names no child link" in capsys.readouterr().err


TWO_LINKS = '<robot name="r"><link name="a"/><link name="b"/><link name="c"/>{joints}</robot>'


def _joint(name: str, parent: str, child: str) -> str:
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/></joint>')


@pytest.mark.parametrize(("joints", "flange", "message"), [
    # a -> b -> a: the walk up from the flange would never reach a root.
    ([("ab", "a", "b"), ("ba", "b", "a")], "b", "the joints above flange 'b' in {urdf} form a "
                                                "loop: 'ba', 'ab'; a URDF is a tree"),
    # The loop lies above the flange's own joint: only its joints are named.
    ([("ac", "a", "c"), ("ab", "a", "b"), ("ba", "b", "a")], "c",
     "the joints above flange 'c' in {urdf} form a loop: 'ab', 'ba'"),
    ([("ab", "a", "b"), ("cb", "c", "b")], "b",
     "link 'b' of {urdf} has two parent joints, 'ab' and 'cb'; a URDF is a tree"),
])
def test_a_urdf_that_is_no_tree_is_refused_naming_its_joints(
        tmp_path: Path, joints: list[tuple[str, str, str]], flange: str, message: str) -> None:
    urdf = tmp_path / "loop.urdf"
    urdf.write_text(TWO_LINKS.format(joints="".join(_joint(*joint) for joint in joints)))
    # A child process, ended after a generous minute: the walk up a loop used to run forever.
    done = subprocess.run([sys.executable, "-m", "vprobot.cli", "robots", "import", str(urdf),
                           "--flange", flange, "--name", "r", "--out", str(tmp_path / "r")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2 and message.format(urdf=urdf) in done.stderr


def test_a_missing_mesh_of_a_found_package_names_the_file_looked_for(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    package = tmp_path / "package"  # found, but without the UR5's meshes
    package.mkdir()
    copied = tmp_path / "ur5.urdf"  # away from its package, whose meshes it would find
    shutil.copy(UR5_URDF, copied)
    assert main(["robots", "import", str(copied), "--flange", "tool0", "--name", "x", "--out",
                 str(tmp_path / "x"), "--package", f"example-robot-data={package}"]) == 2
    err = capsys.readouterr().err
    assert "not found: package 'example-robot-data' has no such file (looked at " in err
    assert str(package / "robots/ur_description/meshes/ur5/collision/base.stl") in err
    assert "--package" not in err.split("looked at")[1]


@pytest.mark.parametrize(("attribute", "value"), [("velocity", "abc"), ("upper", "nan")])
def test_a_limit_that_is_no_number_names_the_joint_attribute_and_file(
        tmp_path: Path, capsys: pytest.CaptureFixture, attribute: str, value: str) -> None:
    text = UR5_URDF.read_text()
    written = f'{attribute}="{"6.28318530718" if attribute == "upper" else "3.15"}"'
    urdf = tmp_path / "ur5.urdf"
    urdf.write_text(text.replace(written, f'{attribute}="{value}"', 1))
    assert main(["robots", "import", str(urdf), "--flange", "tool0", "--name", "x", "--out",
                 str(tmp_path / "x")]) == 2
    assert (f"joint 'shoulder_pan_joint' of {urdf}: <limit {attribute}=...> must be a finite "
            f"number, got '{value}'") in capsys.readouterr().err


@pytest.fixture
def ur5_folder(tmp_path: Path) -> Path:
    folder = tmp_path / "arm"
    shutil.copytree(ROBOTS_DIR / "ur5", folder)
    return folder


def edit_description(folder: Path, **changes: object) -> None:
    path = folder / "robot.yaml"
    data = yaml.safe_load(path.read_text())
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    path.write_text(yaml.safe_dump(data))


@pytest.mark.parametrize(("changes", "message"), [
    ({"flange": None}, r"missing 'flange'; a robot description needs name, model, base, flange"),
    ({"flange": "tool9"}, r"flange 'tool9' is not in ur5\.xml"),
    ({"base": "plinth"}, r"base 'plinth' is not in ur5\.xml|base 'plinth' is not a body"),
    ({"pan_joint": "wrist_1_joint"}, r"pan_joint must be the first joint of the chain "
                                     r"\('shoulder_pan_joint'\)"),
    ({"roll_joint": "knuckle"}, r"roll_joint 'knuckle' is not a joint of the chain"),
    ({"home": [0.0] * 7, "velocity_limits_rad_s": [1.0] * 7,
      "acceleration_limits_rad_s2": [1.0] * 7, "jerk_limits_rad_s3": [1.0] * 7},
     r"home has 7 joints, the chain from 'base_link' to 'tool0' has 6"),
    ({"home": [0.0, 0.0, 4.0, 0.0, 0.0, 0.0]}, r"home\[2\] = 4\.0 lies outside elbow_joint"),
    ({"home": [0.0] * 5}, r"home has 5 joints; vprobot supports arms with 6 or 7 joints"),
    ({"velocity_limits_rad_s": [1.0] * 5}, r"velocity_limits_rad_s has 5 values, home 6"),
    ({"velocity_limits_rad_s": [1.0, 1.0, 1.0, 1.0, 1.0, 0.0]}, r"must be > 0"),
    ({"acceleration_limits_rad_s2": [5.0] * 7},
     r"acceleration_limits_rad_s2 has 7 values, home 6"),
    ({"jerk_limits_rad_s3": [100.0] * 5 + [-1.0]},
     r"jerk_limits_rad_s3 must be > 0, got \[100\.0, .*-1\.0\]"),
    ({"acceleration_limits_rad_s2": [5.0] * 5 + [float("inf")]},
     r"acceleration_limits_rad_s2\[5\] must be finite, got inf"),
    ({"jerk_limits_rad_s3": None},
     r"missing 'jerk_limits_rad_s3'.*add the joints' limits, see "
     r"docs/cell-and-robots\.md#motion-limits"),
    ({"model": "arm.xml"}, r"has no arm\.xml"),
    ({"colour": "blue"}, r"unknown key 'colour'"),
])
def test_a_bad_robot_folder_names_the_missing_piece(ur5_folder: Path, changes: dict,
                                                     message: str) -> None:
    edit_description(ur5_folder, **changes)
    with pytest.raises(ValueError, match=message):
        cell_of(ur5_folder)


def test_bundled_robots_carry_their_makers_limits_or_labelled_assumptions() -> None:
    # Franka's published joint limits of the Panda (FCI docs, "Limits for Panda").
    panda = load_robot("panda")
    assert panda.velocity_limits_rad_s == (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
    # Universal Robots' maximum joint speeds (UR10 and UR5 CB3 user manuals): the UR10's base
    # and shoulder 120 deg/s, its elbow and wrists 180 deg/s; every joint of the UR5 180 deg/s.
    assert load_robot("ur10").velocity_limits_rad_s == pytest.approx(
        np.radians([120, 120, 180, 180, 180, 180]), rel=1e-6)
    assert load_robot("ur5").velocity_limits_rad_s == pytest.approx(np.radians([180] * 6),
                                                                     rel=1e-6)
    assert panda.acceleration_limits_rad_s2 == (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)
    assert panda.jerk_limits_rad_s3 == (7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0,
                                        10000.0)
    for name in ("ur5", "ur10"):
        lines = (ROBOTS_DIR / name / "robot.yaml").read_text().splitlines()
        for key in ("acceleration_limits_rad_s2", "jerk_limits_rad_s3"):
            at = next(i for i, line in enumerate(lines) if line.startswith(f"{key}:"))
            comment = next(i for i in range(at - 1, -1, -1) if lines[i].startswith("# ASSUMPTION"))
            assert all(line.startswith("#") for line in lines[comment:at])


def test_a_folder_without_description_or_home_keyframe_match(ur5_folder: Path) -> None:
    home = [0.0, -1.8, 1.9, -1.57, -1.57, 0.0]
    edit_description(ur5_folder, home=home)
    with pytest.raises(ValueError, match=r"'home' keyframe of ur5\.xml differs from robot\.yaml"):
        cell_of(ur5_folder)
    (ur5_folder / "robot.yaml").unlink()
    with pytest.raises(ConfigError, match=r"has no robot\.yaml"):
        cell_of(ur5_folder)


def test_config_takes_the_robots_own_placement_unless_given() -> None:
    panda = load_robot("panda")
    cell = cell_of("panda")
    np.testing.assert_allclose(cell.robot_base.position, panda.base_position_m)
    # Hanging from the ceiling: the base's z axis points down.
    np.testing.assert_allclose(cell.robot_base.rotation[:, 2], [0.0, 0.0, -1.0], atol=1e-12)
    moved = cell_of("panda", robot_base_position_m=(0.4, 0.1, 1.3), robot_base_tilt_deg=0.0)
    np.testing.assert_allclose(moved.robot_base.position, [0.4, 0.1, 1.3])
    np.testing.assert_allclose(moved.robot_base.rotation, np.eye(3), atol=1e-12)


def test_the_seven_joint_panda_runs_the_env_with_its_robot_state() -> None:
    config = replace(replace(Config(), "cell", robot="panda"), "env", robot_state=True,
                     resolution=(107, 75), parts="mesh", mesh=str(DEFAULT_MOTOR))
    env = InspectEnv(config)
    observation, _ = env.reset(seed=0)
    assert env.observation_space["robot"].shape == (3 + 6 + 7,)
    assert env.observation_space.contains(observation)
    for _ in range(3):
        observation, _, terminated, truncated, _ = env.step(env.action_space.sample())
        assert env.observation_space.contains(observation)
        if terminated or truncated:
            break
    np.testing.assert_allclose(observation["robot"][-7:] * 2.0 * np.pi, env.episode.q,
                               atol=1e-6)
    env.close()


def test_panda_ik_round_trip_within_its_limits() -> None:
    arm = RobotArm(cell_of("panda"))
    rng = np.random.default_rng(5)
    reached = 0
    for _ in range(40):
        q = rng.uniform(arm.joints.lower, arm.joints.upper)
        if arm.collisions.in_collision(q):
            continue
        goal = arm.fk(q)
        result = arm.reach(SensorTarget.full_pose(goal.position, goal.quaternion),
                           arm.joints.start)
        if result.reachable:
            reached += 1
            assert arm.joints.within_limits(result.q)
            np.testing.assert_allclose(arm.fk(result.q).position, goal.position, atol=1e-3)
    assert reached >= 10


def test_reach_with_the_panda_exports_joints_franka_dh_agrees_with(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "view.json"
    code = main(["reach", "--robot", "panda", "--position", "0.45", "-0.47", "0.75", "--look-at",
                 "0.45", "0", "0.75", "--json", str(out)])
    assert code == 0, capsys.readouterr().out
    plan = json.loads(out.read_text())
    assert plan["robot"]["name"] == "panda"
    assert plan["robot"]["sensor_mount"]["parent"] == "panda_link8"
    (view,) = plan["views"]
    assert len(view["joints"]) == 7
    # Franka's DH table, the config's (default: the Panda's own) base placement and mount.
    pose = world_sensor(np.array(view["joints"]), replace(Config(), "cell", robot="panda"))
    assert np.linalg.norm(pose[:3, 3] - [0.45, -0.47, 0.75]) <= 1e-3
    assert rotation_difference(pose[:3, :3], quaternion_matrix(view["quaternion"])) <= 1e-3


@pytest.fixture(scope="module")
def imported_ur5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """example-robot-data's UR5 imported once, as `robots/six` under a work folder, with the
    bundled UR5's home (the zero pose stretches the arm through the fixture's pedestal, a start
    pose the cell refuses)."""
    out = tmp_path_factory.mktemp("work") / "robots" / "six"
    assert main(["robots", "import", str(UR5_URDF), "--flange", "tool0", "--name", "six",
                 "--out", str(out), "--home", *map(str, load_robot("ur5").home)]) == 0
    return out


def test_an_imported_robot_folder_has_the_umask_mode(imported_ur5: Path) -> None:
    umask = os.umask(0)
    os.umask(umask)
    expected = 0o777 & ~umask  # 755 under the usual umask 022, not mkdtemp's 700
    assert imported_ur5.stat().st_mode & 0o777 == expected
    assert (imported_ur5 / "meshes").stat().st_mode & 0o777 == expected


def test_import_force_refuses_a_folder_that_is_no_robot_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    folder = tmp_path / "F"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    code = main(["robots", "import", str(UR5_URDF), "--flange", "tool0", "--name", "six",
                 "--out", str(folder), "--force"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert str(folder) in err and "no robot folder" in err and "--force" in err
    assert [p.name for p in folder.iterdir()] == ["notes.txt"]
    assert (folder / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["F"]  # no hidden build folder left


def test_import_force_replaces_an_existing_robot_folder(
        imported_ur5: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    folder = tmp_path / "six"
    shutil.copytree(imported_ur5, folder)
    argv = ["robots", "import", str(UR5_URDF), "--flange", "tool0", "--name", "six", "--out",
            str(folder), "--base-yaw", "30"]
    assert main(argv) == 2
    assert "exists" in capsys.readouterr().err and load_robot(str(folder)).base_yaw_deg == 0.0
    assert main([*argv, "--force"]) == 0
    assert load_robot(str(folder)).base_yaw_deg == 30.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["six"]


def test_import_check_errors_name_the_folder_asked_for_not_the_build_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    from vprobot.robots.description import RobotDescription

    def failing_check(self: RobotDescription, model: object) -> list[int]:
        raise ValueError(f"robot {self.name} ({self.folder / 'robot.yaml'}): a broken piece")

    monkeypatch.setattr(RobotDescription, "check_model", failing_check)
    monkeypatch.chdir(tmp_path)
    code = main(["robots", "import", str(UR5_URDF), "--flange", "tool0", "--name", "six"])
    err = capsys.readouterr().err
    assert code == 2
    assert "robots/six/robot.yaml" in err and "ur5_robot.urdf" in err and ".six." not in err
    assert list((tmp_path / "robots").iterdir()) == []


def replay_plan(plan: Path) -> None:
    """Replay a plan the way `render --plan` does and check it restores the planned cell."""
    document = json.loads(plan.read_text())
    scene, record = episode_from_plan(load_config(), plan)
    base = scene.cell.robot_base
    np.testing.assert_allclose(base.position, document["robot"]["base_position"], atol=1e-9)
    np.testing.assert_allclose(np.abs(base.quaternion @ document["robot"]["base_quaternion"]),
                               1.0, atol=1e-9)
    assert list(scene.cell.joints.names) == document["robot"]["joint_names"]
    assert len(record.views) == len(document["views"])
    assert record.coverage == pytest.approx(document["coverage"], abs=1e-9)


@pytest.mark.parametrize("robot", ["ur10", "ur5", "panda"])
def test_a_plan_of_every_bundled_robot_reads_its_description_once_and_replays(
        robot: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture) -> None:
    from vprobot.robots import _load_description
    from vprobot.robots.description import RobotDescription

    loads: list[Path] = []
    load = RobotDescription.load.__func__  # type: ignore[attr-defined]

    def counting(cls: type[RobotDescription], folder: Path) -> RobotDescription:
        loads.append(Path(folder))
        return load(cls, folder)

    monkeypatch.setattr(RobotDescription, "load", classmethod(counting))
    _load_description.cache_clear()  # as in a fresh process
    plan = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--robot", robot, "--planner", "hrec", "--carrier",
                 "robot",
                 "--out", str(plan)]) == 0, capsys.readouterr().err
    # The config, the cell and the fit checks of the plan share one read of robot.yaml (the
    # default config's ur10 is read too, when the config is loaded before --robot replaces it).
    assert loads.count(ROBOTS_DIR / robot) == 1 and len(set(loads)) == len(loads)
    assert json.loads(plan.read_text())["robot"]["name"] == robot
    assert "folder" not in json.loads(plan.read_text())["robot"]  # bundled: named only
    replay_plan(plan)


def test_a_plan_of_an_imported_robot_replays_from_another_folder(
        imported_ur5: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(imported_ur5.parent.parent)
    plan = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--robot", "robots/six", "--planner", "hrec", "--out",
                 str(plan)]) == 0
    robot = json.loads(plan.read_text())["robot"]
    assert robot["name"] == "six" and robot["folder"] == str(imported_ur5.resolve())
    monkeypatch.chdir(tmp_path)
    replay_plan(plan)
    capsys.readouterr()
    # The plan fixes the robot: a --robot beside --plan is refused, not silently ignored.
    assert main(["render", "--plan", str(plan), "--robot", "ur5", "--out", "v.gif"]) == 2
    assert "--robot" in capsys.readouterr().err
