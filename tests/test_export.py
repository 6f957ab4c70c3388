"""`vprobot export` and `vprobot check`: every format read back by an independent parser and held
to the plan (its corners, joints and poses) and to the robot's limits (its `robot.yaml`), and the
replay check failing on tampered plans."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from vprobot.cli import main
from vprobot.export.formats import FORMATS
from vprobot.export.program import export_plan
from vprobot.files.paths import ROBOTS_DIR

VIEWS = 10
SAFE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
"""libyaml's safe loader where PyYAML was built with it: a 3000-point message takes it 1 s, the
pure-Python one 20 s."""


@pytest.fixture(scope="module")
def plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 10-view nbv plan of the bundled motor with the UR10 (some moves go around obstacles)."""
    path = tmp_path_factory.mktemp("export") / "plan.json"
    assert main(["plan", "--no-summary", "--planner", "nbv", "--stop", f"views:{VIEWS}",
                 "--no-timing",
                 "--out", str(path)]) == 0
    return path


@pytest.fixture
def document(plan: Path) -> dict[str, Any]:
    return json.loads(plan.read_text())


def robot_limits(name: str) -> dict[str, np.ndarray]:
    """The robot's limits read straight from its robot.yaml (not the plan's copy)."""
    description = yaml.safe_load((ROBOTS_DIR / name / "robot.yaml").read_text())
    return {key: np.array(description[f"{key}_limits_{unit}"]) for key, unit in
            (("velocity", "rad_s"), ("acceleration", "rad_s2"), ("jerk", "rad_s3"))}


def moves_of(document: dict[str, Any]) -> list[tuple[list[np.ndarray], int | None]]:
    """The plan's moves as (corners after the first, the view acquired at the end; None for the
    return)."""
    moves = [([np.array(q) for q in view["waypoints"][1:]], index)
             for index, view in enumerate(document["views"]) if view["waypoints"] is not None]
    return [*moves, ([np.array(q) for q in document["return"]["waypoints"][1:]], None)]


def write(document: dict[str, Any], folder: Path, name: str = "plan.json") -> Path:
    path = folder / name
    path.write_text(json.dumps(document))
    return path


def test_the_plan_records_each_move_the_return_and_the_cycle_time(
        document: dict[str, Any]) -> None:
    moves = [view["waypoints"] for view in document["views"] if view["waypoints"] is not None]
    assert len(moves) == VIEWS
    at = document["start_joints"]
    for move, view in zip([*moves, document["return"]["waypoints"]],
                          [*document["views"], {"joints": document["start_joints"]}],
                          strict=True):
        assert move[0] == at and move[-1] == view["joints"] and len(move) >= 2
        at = move[-1]
    assert document["return"]["reason"] is None
    cycle = document["cycle_time"]
    assert cycle["total_s"] == pytest.approx(cycle["approach_s"] + cycle["moves_s"]
                                             + cycle["acquisitions_s"] + cycle["return_s"])
    assert cycle["acquisitions_s"] == pytest.approx(
        VIEWS * document["sensor"]["acquisition_time_s"])


URSCRIPT_STATEMENTS = {
    # The body of `inspection()`: statements indented by two spaces (a helper's body is deeper).
    "move": re.compile(r"  movej\(\[([^\]]*)\], a=(\S+) \* speed_scale \* speed_scale, "
                       r"v=(\S+) \* speed_scale\)(?:  #.*)?"),
    "trigger": re.compile(r"  set_standard_digital_out\((\d+), True\)"),
    "release": re.compile(r"  set_standard_digital_out\((\d+), False\)"),
    "sleep": re.compile(r"  sleep\(([^)]+)\)"),
    "wait": re.compile(r"  wait_for_frame\((\d+)\)"),
    "view": re.compile(r"  # view (\d+) \(acquisition .*: sensor p\[([^\]]*)\] "
                       r"in the base frame.*"),
}


def parse_urscript(program: str, trigger_script: str | None = None) -> list[tuple[Any, ...]]:
    """The program's moves, triggers, waits and pose comments in order, read by regexes: every
    `movej` of the program must be one of the speed-scaled moves."""
    events: list[tuple[Any, ...]] = []
    for line in program.splitlines():
        if trigger_script is not None and line == f"  {trigger_script}":
            events.append(("script",))
            continue
        for kind, pattern in URSCRIPT_STATEMENTS.items():
            match = pattern.fullmatch(line)
            if match is not None:
                events.append((kind, *match.groups()))
                break
        else:
            assert "movej(" not in line, line
    return events


def floats(text: str) -> np.ndarray:
    return np.array([float(x) for x in text.split(",")])


def expected_urscript(document: dict[str, Any]) -> list[tuple[str, Any]]:
    """What the program must do, from the plan: the move to the start, every corner of every
    move, and at each view its pose comment, the trigger and the wait, by the plan's I/O."""
    program = document["cell"]["program"]
    acquire: list[tuple[str, Any]] = []
    if program["trigger_output"] is not None:
        output = str(program["trigger_output"])
        acquire += [("trigger", output), ("sleep", None), ("release", output)]
    else:
        acquire.append(("script", None))
    done = program["done_input"] is not None
    expected: list[tuple[str, Any]] = [("move", np.array(document["start_joints"]))]
    for corners, acquired in moves_of(document):
        expected += [("move", corner) for corner in corners]
        if acquired is not None:
            expected += [("view", acquired), *acquire,
                         ("wait", acquired) if done else ("sleep", None)]
    return expected


def test_urscript_moves_through_the_plans_corners_and_acquires_in_view_order(
        document: dict[str, Any]) -> None:
    # A corner halfway along a move's line: the program must move in two segments there.
    view = document["views"][1]
    start, end = np.array(view["waypoints"][0]), np.array(view["waypoints"][-1])
    view["waypoints"].insert(1, ((start + end) / 2).tolist())
    document["cycle_time"] = None  # no longer the plan's
    events = parse_urscript(export_plan(document, "urscript"))
    expected = expected_urscript(document)
    assert [event[0] for event in events] == [kind for kind, _ in expected]
    duration = 0.0
    limits = robot_limits("ur10")
    position = np.array(document["start_joints"])
    for event, (kind, wanted) in zip(events[1:], expected[1:], strict=True):
        if kind == "move":
            target, a, v = floats(event[1]), float(event[2]), float(event[3])
            assert np.array_equal(target, wanted)
            step = np.abs(target - position)
            share = step / step.max()
            # a and v are the leading joint's; every joint moves at its share of them.
            assert np.all(share * a <= limits["acceleration"] * (1 + 1e-12))
            assert np.all(share * v <= limits["velocity"] * (1 + 1e-12))
            duration += step.max() / v + v / a  # the trapezoid's duration
            position = target
        elif kind == "sleep":
            duration += float(event[1])
        elif wanted is not None:
            assert event[1] == str(wanted)
    # The midpoint adds no travel, only a stop: the program runs the plan's clock (the trigger
    # pulse is part of the acquisition time).
    assert duration == pytest.approx(json.loads(export_plan(document, "trajectory"))
                                     ["cycle_time"]["total_s"], rel=1e-9)


def rotation_of(quaternion_wxyz: list[float]) -> Rotation:
    w, x, y, z = quaternion_wxyz
    return Rotation.from_quat([x, y, z, w])


def test_urscript_is_a_program_that_sets_tcp_and_payload_and_states_poses_in_the_ur_base(
        document: dict[str, Any]) -> None:
    # A base turned and tilted, so the base transform is not a sign flip of x and y.
    document["robot"]["base_position"] = [0.2, -0.1, 0.8]
    base = Rotation.from_euler("zy", [0.7, 0.1])
    x, y, z, w = base.as_quat()
    document["robot"]["base_quaternion"] = [w, x, y, z]
    program = export_plan(document, "urscript")
    lines = program.splitlines()
    # A global speed scale, the function defined and then called; a scale outside (0, 1] stops.
    assert lines.index("speed_scale = 1.0") < lines.index("def inspection():")
    assert lines[-2:] == ["end", "inspection()"]
    check = lines.index("  if speed_scale <= 0 or speed_scale > 1:")
    assert lines[check + 1].lstrip().startswith("popup(") and lines[check + 2] == "    halt"
    # The TCP is the sensor mount on the flange, its rotation as a rotation vector.
    mount = document["robot"]["sensor_mount"]
    tcp = re.search(r"^  set_tcp\(p\[([^\]]*)\]\)$", program, re.MULTILINE)
    assert tcp is not None
    assert np.allclose(floats(tcp.group(1)), [*mount["position"], *rotation_of(
        mount["quaternion"]).as_rotvec()], atol=1e-12)
    # The payload: the cell's mass at the housing's centre, in the flange frame.
    payload = re.search(r"^  set_payload\(([^,]+), \[([^\]]*)\]\)", program, re.MULTILINE)
    assert payload is not None
    assert float(payload.group(1)) == document["cell"]["payload_kg"]
    housing = document["cell"]["housing"]["position_m"]
    assert np.allclose(floats(payload.group(2)), np.array(mount["position"]) + rotation_of(
        mount["quaternion"]).apply(housing), atol=1e-12)
    assert "estimate" in program.split("set_payload(")[1].splitlines()[0]
    # The first move goes to the start pose, slowly: at most 0.3 rad/s and 0.5 rad/s^2.
    events = parse_urscript(program)
    assert events[0][0] == "move" and np.array_equal(floats(events[0][1]),
                                                     document["start_joints"])
    assert float(events[0][2]) <= 0.5 and float(events[0][3]) <= 0.3
    first = next(index for index, line in enumerate(lines) if "movej(" in line)
    assert "not collision-checked" in lines[first - 1]
    # Each view's pose comment: the plan's world pose in UR's base frame, ROS base_link turned
    # 180 deg about z.
    ur_base_rotation = base * Rotation.from_euler("z", np.pi)
    ur_base_position = np.array(document["robot"]["base_position"])
    poses = [event for event in events if event[0] == "view"]
    assert [int(index) for _, index, _ in poses] == list(range(VIEWS))
    for _, index, text in poses:
        view = document["views"][int(index)]
        pose = floats(text)
        position = ur_base_rotation.inv().apply(np.array(view["position"]) - ur_base_position)
        rotation = ur_base_rotation.inv() * rotation_of(view["quaternion"])
        assert np.allclose(pose[:3], position, atol=1e-12)
        assert (Rotation.from_rotvec(pose[3:]).inv() * rotation).magnitude() < 1e-9
        assert np.linalg.norm(pose[3:]) <= np.pi + 1e-12


@pytest.mark.parametrize(
    "program",
    [{"trigger_output": 5, "done_input": 3, "done_timeout_s": 2.5},
     {"trigger_output": None, "trigger_script": "phoxi_trigger(1)", "done_input": None}],
)
def test_urscript_triggers_and_waits_as_the_cell_says(program: dict[str, Any],
                                                      document: dict[str, Any]) -> None:
    document["cell"]["program"].update(program)
    text = export_plan(document, "urscript")
    events = parse_urscript(text, program.get("trigger_script"))
    expected = expected_urscript(document)
    assert [event[0] for event in events] == [kind for kind, _ in expected]
    for event, (kind, wanted) in zip(events, expected, strict=True):
        if kind in ("trigger", "release", "wait", "view"):
            assert event[1] == str(wanted)
    if program["done_input"] is not None:
        # The wait reads the done input and stops the program after the timeout.
        body = text.split("  def wait_for_frame(view):\n")[1].split("\n  end\n")[0]
        assert "while not get_standard_digital_in(3):" in body
        assert "if waited >= 2.5:" in body and "popup(" in body and "halt" in body
    else:
        acquisition_time = document["sensor"]["acquisition_time_s"]
        assert [float(event[1]) for event in events if event[0] == "sleep"] == [
            acquisition_time] * VIEWS


def test_urscript_of_a_plan_without_a_cell_block_takes_the_defaults_and_says_so(
        document: dict[str, Any]) -> None:
    del document["cell"]
    program = export_plan(document, "urscript")
    assert "DEFAULTS: the plan has no cell block" in program
    # The sensor of the plans before the cell block: 0.8 kg, its housing centred 0.04 m behind
    # the sensor frame, 0.09 m out on the flange's z axis.
    payload = re.search(r"^  set_payload\(([^,]+), \[([^\]]*)\]\)", program, re.MULTILINE)
    assert payload is not None and float(payload.group(1)) == 0.8
    assert np.allclose(floats(payload.group(2)), [0.0, 0.0, 0.05], atol=1e-12)
    assert program.count("  set_standard_digital_out(0, True)") == VIEWS


GOAL_FIELDS = ("trajectory", "multi_dof_trajectory", "path_tolerance",
               "component_path_tolerance", "goal_tolerance", "component_goal_tolerance",
               "goal_time_tolerance")
"""The fields of control_msgs/action/FollowJointTrajectory's goal (control_msgs, Humble and
later), in order: the message YAML `ros2 action send_goal` reads may hold only these."""
JOINT_TOLERANCE_FIELDS = ("name", "position", "velocity", "acceleration")
"""control_msgs/msg/JointTolerance."""


def test_ros2_yaml_is_a_follow_joint_trajectory_goal_whose_times_increase(
        document: dict[str, Any]) -> None:
    document["cell"]["program"].update(path_tolerance_rad=0.03, goal_tolerance_rad=0.002,
                                       goal_time_tolerance_s=1.25)
    text = export_plan(document, "ros2")
    goal = yaml.load(text, Loader=SAFE_LOADER)
    assert set(goal) == {"trajectory", "path_tolerance", "goal_tolerance", "goal_time_tolerance"}
    assert set(goal) <= set(GOAL_FIELDS)
    names = document["robot"]["joint_names"]
    for key, position in (("path_tolerance", 0.03), ("goal_tolerance", 0.002)):
        assert [tuple(entry) for entry in goal[key]] == [JOINT_TOLERANCE_FIELDS] * len(names)
        assert [entry["name"] for entry in goal[key]] == names
        assert all(entry["position"] == position and entry["velocity"] == 0.0
                   and entry["acceleration"] == 0.0 for entry in goal[key])
    assert goal["goal_time_tolerance"] == {"sec": 1, "nanosec": 250_000_000}
    message = goal["trajectory"]
    assert set(message) == {"header", "joint_names", "points"}
    assert message["joint_names"] == names
    points = message["points"]
    for point in points:
        assert set(point) == {"positions", "velocities", "accelerations", "time_from_start"}
        assert all(len(point[key]) == 6 for key in ("positions", "velocities", "accelerations"))
        assert set(point["time_from_start"]) == {"sec", "nanosec"}
        assert 0 <= point["time_from_start"]["nanosec"] < 1_000_000_000
    times = np.array([p["time_from_start"]["sec"] + p["time_from_start"]["nanosec"] * 1e-9
                      for p in points])
    assert np.all(np.diff(times) > 0)
    assert times[-1] == pytest.approx(document["cycle_time"]["total_s"], abs=1e-9)
    assert points[0]["positions"] == points[-1]["positions"] == document["start_joints"]
    # Each acquisition comment precedes the point where the robot stands at its view, and the
    # robot stands there for the acquisition time.
    acquired, following = [], 0
    for line in text.splitlines():
        following += line.startswith("    - positions:")
        found = re.match(r"\s*# acquisition view (\d+)", line)
        if found:
            index = int(found.group(1))
            assert str(document["views"][index]["position"]) in line
            acquired.append(index)
            start = times[following]  # the next point's
            still = (times >= start) & (times <= start + document["sensor"]
                                        ["acquisition_time_s"] + 1e-9)
            assert still.sum() >= 2
            assert np.allclose([p["positions"] for p, s in zip(points, still, strict=True) if s],
                               document["views"][index]["joints"], atol=1e-12, rtol=0)
    assert acquired == list(range(VIEWS))
    assert "--format acquisitions" in text.split("\n", 2)[1]


def test_the_acquisitions_beside_the_ros2_goal_are_the_plans_views_at_its_points(
        document: dict[str, Any]) -> None:
    acquisitions = json.loads(export_plan(document, "acquisitions"))["acquisitions"]
    points = yaml.load(export_plan(document, "ros2"), Loader=SAFE_LOADER)["trajectory"]["points"]
    nanoseconds = {p["time_from_start"]["sec"] * 1_000_000_000 + p["time_from_start"]["nanosec"]:
                   p["positions"] for p in points}
    assert [entry["view"] for entry in acquisitions] == list(range(VIEWS))
    for entry in acquisitions:
        view = document["views"][entry["view"]]
        assert entry["joints"] == view["joints"]
        assert entry["sensor_position"] == view["position"]
        assert entry["sensor_quaternion"] == view["quaternion"]
        assert entry["end_s"] - entry["start_s"] == pytest.approx(
            document["sensor"]["acquisition_time_s"])
        # The goal has a point at the start and the end of each stop, at the view's joints.
        for time_s in (entry["start_s"], entry["end_s"]):
            assert nanoseconds[round(time_s * 1e9)] == view["joints"]


def divided(times: np.ndarray, values: np.ndarray, order: int) -> np.ndarray:
    """order! f[t_i, ..., t_i+order], the textbook estimate of the order-th derivative."""
    for k in range(1, order + 1):
        values = (values[1:] - values[:-1]) / (times[k:] - times[:-k])[:, None]
    return values * math.factorial(order)


def test_csv_finite_differences_respect_the_robots_limits(document: dict[str, Any]) -> None:
    lines = export_plan(document, "csv", dt=0.004).splitlines()
    comments = [line for line in lines if line.startswith("#")]
    rows = list(csv.reader(line for line in lines if not line.startswith("#")))
    header, rows = rows[0], rows[1:]
    names = document["robot"]["joint_names"]
    assert header == ["time_s", *(f"q_{n}" for n in names), *(f"qd_{n}" for n in names), "view"]
    table = np.array([[float(x) for x in row] for row in rows])
    times, positions, view = table[:, 0], table[:, 1:7], table[:, -1].astype(int)
    assert np.all(np.diff(times) > 0)
    limits = robot_limits("ur10")
    for order, key in enumerate(("velocity", "acceleration", "jerk"), 1):
        estimate = np.abs(divided(times, positions, order))
        assert np.all(estimate <= limits[key] * (1 + 1e-6)), key
        assert estimate.max() > 0.5 * limits[key].min(), key  # it does move, near its limits
    # The view column marks each acquisition at its view's joints, in view order.
    assert [int(v) for v in dict.fromkeys(view[view >= 0])] == list(range(VIEWS))
    for index in range(VIEWS):
        assert np.allclose(positions[view == index], document["views"][index]["joints"],
                           atol=1e-12, rtol=0)
        assert f"# acquisition view {index}: sensor position " \
               f"{document['views'][index]['position']}" in "\n".join(comments)


def test_trajectory_json_holds_the_samples_and_the_sensor_pose_at_each_acquisition(
        document: dict[str, Any]) -> None:
    exported = json.loads(export_plan(document, "trajectory"))
    assert exported["joint_names"] == document["robot"]["joint_names"]
    assert exported["cycle_time"] == pytest.approx(document["cycle_time"])
    times = np.array(exported["times"])
    assert np.all(np.diff(times) > 0) and times[-1] == pytest.approx(
        document["cycle_time"]["total_s"])
    for key in ("positions", "velocities", "accelerations"):
        assert np.array(exported[key]).shape == (len(times), 6)
    for entry, view in zip(exported["acquisitions"], document["views"], strict=True):
        assert entry["sensor_position"] == view["position"]
        assert entry["sensor_quaternion"] == view["quaternion"]
        assert entry["joints"] == view["joints"]
        assert entry["end_s"] - entry["start_s"] == pytest.approx(
            document["sensor"]["acquisition_time_s"])


def test_every_format_is_written_by_the_command(plan: Path, tmp_path: Path,
                                                capsys: pytest.CaptureFixture) -> None:
    for name, form in FORMATS.items():
        out = tmp_path / f"out{form.suffix}"
        assert main(["export", str(plan), "--format", name, "--out", str(out)]) == 0
        assert out.stat().st_size > 0
    assert capsys.readouterr().out.count("wrote ") == len(FORMATS)


def test_a_10_view_plan_exports_every_format_with_each_acquisition(
        document: dict[str, Any]) -> None:
    # How long this takes is `vprobot benchmark motion`'s (export_10_views), not a test's.
    texts = {name: export_plan(document, name) for name in FORMATS}
    assert texts["urscript"].count("set_standard_digital_out(0, True)") == VIEWS
    assert len(json.loads(texts["acquisitions"])["acquisitions"]) == VIEWS


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d.update(carrier="free"), "free-flying sensor has no robot program"),
        (lambda d: d.pop("return"), "written before export existed"),
        (lambda d: d.update({"return": {"waypoints": None, "reason": "no_path_back"}}),
         "cycle is not closed (no_path_back)"),
        (lambda d: d["views"][2]["joints"].__setitem__(0, 0.5),
         "views[2].joints are not the last of its waypoints"),
    ],
)
def test_export_refuses_what_has_no_program_in_one_line(
        change: Any, message: str, document: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    change(document)
    path = write(document, tmp_path)
    assert main(["export", str(path), "--format", "urscript", "--out",
                 str(tmp_path / "x.script")]) == 2
    error = capsys.readouterr().err
    assert message in error and len(error.strip().splitlines()) == 1
    assert not (tmp_path / "x.script").exists()


def test_a_plan_without_its_object_exports_but_is_not_checked(
        document: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The robot's motion needs no object: reading the plan does not refuse it for export
    (the object block is what the replay of `check` and `render` need, and they say so)."""
    expected = export_plan(document, "trajectory")
    document["object"] = None
    path = write(document, tmp_path)
    out = tmp_path / "trajectory.json"
    assert main(["export", str(path), "--format", "trajectory", "--out", str(out)]) == 0
    assert out.read_text() == expected
    capsys.readouterr()
    assert main(["check", str(path)]) == 2
    error = capsys.readouterr().err
    assert "has no object block (mesh and pose)" in error
    assert len(error.strip().splitlines()) == 1


def test_export_never_writes_over_the_plan(plan: Path, capsys: pytest.CaptureFixture) -> None:
    before = plan.read_text()
    assert main(["export", str(plan), "--format", "trajectory", "--out", str(plan)]) == 2
    assert "is the plan itself" in capsys.readouterr().err
    assert plan.read_text() == before


def test_check_holds_on_the_plan(plan: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["check", str(plan)]) == 0
    out = capsys.readouterr().out
    assert "check holds" in out and "FAILED" not in out


def colliding_corner(document: dict[str, Any], plan: Path) -> list[float]:
    """A configuration near the first view's in which the sensor or the arm is in the object."""
    from vprobot.config import load_config
    from vprobot.export.check import _cell
    from vprobot.kinematics.collision import CollisionChecker

    cell, rotation = _cell(load_config(None), document, plan)
    checker = CollisionChecker(cell, rotation)
    rng = np.random.default_rng(0)
    view = np.array(document["views"][0]["joints"])
    for _ in range(5000):
        q = view + rng.normal(0.0, 0.4, len(view))
        if cell.joints.within_limits(q) and any(
                "object" in pair for pair in checker.colliding_pairs(q)):
            return q.tolist()
    raise AssertionError("no configuration touching the object was found")


def test_check_fails_on_a_corner_moved_into_the_object(
        document: dict[str, Any], plan: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    document["views"][0]["waypoints"].insert(1, colliding_corner(document, plan))
    assert main(["check", str(write(document, tmp_path))]) == 1
    out = capsys.readouterr().out
    assert re.search(r"collision at t=[\d.]+ s \(sample \d+\): .*object", out)
    assert "collision on move 0 (the approach)" in out


@pytest.mark.parametrize(("shift_m", "holds"), [(0.00005, True), (0.001, False)])
def test_check_holds_views_to_a_tenth_of_a_millimetre(
        shift_m: float, holds: bool, document: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    document["views"][3]["position"][0] += shift_m
    assert main(["check", str(write(document, tmp_path))]) == (0 if holds else 1)
    out = capsys.readouterr().out
    assert ("sensor pose at view 3" in out) != holds


def test_check_fails_on_a_plan_timed_beyond_the_robots_limits(
        document: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # The plan claims twice the velocities: the replay holds it to robot.yaml's.
    document["robot"]["limits"]["velocity_rad_s"] = [
        2 * v for v in document["robot"]["limits"]["velocity_rad_s"]]
    assert main(["check", str(write(document, tmp_path))]) == 1
    out = capsys.readouterr().out
    assert re.search(r"velocity limit exceeded at t=[\d.]+ s \(sample \d+\): \w+_joint", out)
    assert "the plan states" in out


def test_a_free_flying_plan_has_no_return_nor_cycle_and_no_program(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "free.json"
    assert main(["plan", "--no-summary", "--planner", "uniform4", "--carrier", "free",
                 "--no-timing", "--out",
                 str(path)]) == 0
    document = json.loads(path.read_text())
    assert document["return"] is None and document["cycle_time"] is None
    assert all("waypoints" not in view for view in document["views"])
    capsys.readouterr()
    assert main(["check", str(path)]) == 2
    assert "free-flying sensor has no robot program" in capsys.readouterr().err


def test_check_holds_on_a_panda_plan_which_gets_no_urscript(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    path = tmp_path / "panda.json"
    assert main(["plan", "--no-summary", "--planner", "bscp", "--views", "2", "--robot", "panda",
                 "--no-timing",
                 "--out", str(path)]) == 0
    capsys.readouterr()
    assert main(["check", str(path)]) == 0
    assert "check holds" in capsys.readouterr().out
    assert main(["export", str(path), "--format", "urscript", "--out",
                 str(tmp_path / "panda.script")]) == 2
    assert "the plan's robot is 'panda'" in capsys.readouterr().err
    assert main(["export", str(path), "--format", "ros2", "--out",
                 str(tmp_path / "panda.yaml")]) == 0
    goal = yaml.safe_load((tmp_path / "panda.yaml").read_text())
    assert len(goal["trajectory"]["joint_names"]) == len(goal["goal_tolerance"]) == 7


def sample_times(format_name: str, text: str) -> np.ndarray:
    """The sample times (s) of an exported trajectory, read back by an independent parser:
    integer nanoseconds for the ROS 2 message, floats otherwise."""
    if format_name == "ros2":
        return np.array([p["time_from_start"]["sec"] * 1_000_000_000
                         + p["time_from_start"]["nanosec"]
                         for p in yaml.load(text, Loader=SAFE_LOADER)["trajectory"]["points"]]
                        ) * 1e-9
    if format_name == "trajectory":
        return np.array(json.loads(text)["times"])
    rows = list(csv.reader(line for line in text.splitlines() if not line.startswith("#")))
    return np.array([float(row[0]) for row in rows[1:]])


@pytest.mark.parametrize("format_name", ["ros2", "trajectory", "csv"])
def test_every_sampled_format_has_times_at_least_a_microsecond_apart(
        format_name: str, document: dict[str, Any]) -> None:
    # The plan of `plan --planner nbv --stop views:10`: the return's end and the cycle's total
    # lie ulps apart (issue 42), and a ROS 2 controller refuses a repeated time. Those are
    # sampled at every step; a coarse one keeps the file quick to parse.
    times = sample_times(format_name, export_plan(document, format_name, dt=0.1))
    # The ROS 2 message rounds each time to the nanosecond.
    margin = 1e-6 - (1e-9 if format_name == "ros2" else 0.0)
    assert np.diff(times).min() >= margin
    assert times[0] == 0.0
    assert times[-1] == pytest.approx(document["cycle_time"]["total_s"], abs=1e-9)


INJECTED = 'shoulder_pan_joint\nend\npopup("INJECTED")\ndef x():'


@pytest.mark.parametrize(
    ("change", "format_name", "message"),
    [
        # Lines that would run as top-level URScript.
        (lambda d: d["robot"]["joint_names"].__setitem__(0, INJECTED), "urscript",
         "plan robot.joint_names[0] must be a name of"),
        # A YAML key of its own, a split CSV header, a quoted YAML scalar.
        (lambda d: d["robot"].update(name="ur10\nheader: {evil: 1}"), "ros2",
         "plan robot.name must be a name of"),
        (lambda d: d["robot"]["joint_names"].__setitem__(1, "elbow,joint"), "csv",
         "plan robot.joint_names[1] must be a name of"),
        (lambda d: d["robot"]["joint_names"].__setitem__(2, 'a", "b'), "ros2",
         "plan robot.joint_names[2] must be a name of"),
        # Names any format could write, but not the robot's.
        (lambda d: d["robot"]["joint_names"].__setitem__(0, "shoulder_pan"), "urscript",
         "are not the robot's"),
        (lambda d: d["robot"].update(name="panda"), "trajectory", "are not the robot's"),
    ],
)
def test_export_checks_the_names_against_the_robot_before_writing_them(
        change: Any, format_name: str, message: str, document: dict[str, Any],
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    change(document)
    out = tmp_path / f"out{FORMATS[format_name].suffix}"
    assert main(["export", str(write(document, tmp_path)), "--format", format_name,
                 "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert message in error and len(error.strip().splitlines()) == 1
    assert not out.exists()


def test_check_dt_is_bounded_and_a_plan_timed_over_the_limits_fails_at_the_coarsest(
        document: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from vprobot.export.motion import plan_motion

    # Timed at 1.5 times every limit, its cycle time restated: only the limits are wrong.
    for key, values in document["robot"]["limits"].items():
        document["robot"]["limits"][key] = [1.5 * value for value in values]
    document["cycle_time"] = plan_motion(document).timed.cycle.as_dict()
    path = write(document, tmp_path)
    # At 10 s the divided differences average every peak away ("check holds" before).
    with pytest.raises(SystemExit) as exit_:  # argparse's refusal
        main(["check", str(path), "--dt", "10"])
    assert exit_.value.code == 2
    error = capsys.readouterr().err
    assert "--dt" in error and "[0.0001, 0.008]" in error
    assert main(["check", str(path), "--dt", "0.008"]) == 1
    out = capsys.readouterr().out
    for key in ("velocity_rad_s", "acceleration_rad_s2", "jerk_rad_s3"):
        assert f"timed under robot.limits.{key} above the robot's" in out


def test_a_nan_sample_fails_the_limit_check() -> None:
    from vprobot.export.check import limit_failures
    from vprobot.kinematics.trajectory import Trajectory
    from vprobot.robots.description import MotionLimits

    times = np.linspace(0.0, 1.0, 11)
    positions = np.zeros((11, 2))
    positions[5, 1] = np.nan
    samples = Trajectory(times, positions, positions, positions, ("a", "b"), ())
    limits = MotionLimits(np.ones(2), np.ones(2), np.ones(2))
    _, failures = limit_failures(samples, limits)
    assert [failure.split(" limit")[0] for failure in failures] == [
        "velocity", "acceleration", "jerk"]
    assert all(": b nan > 1" in failure for failure in failures)


def set_at(path: tuple[Any, ...], value: Any) -> Any:
    """A change of the plan that sets the entry at `path` to `value`."""

    def change(document: dict[str, Any]) -> None:
        block = document
        for key in path[:-1]:
            block = block[key]
        block[path[-1]] = value

    return change


@pytest.mark.parametrize(
    ("command", "change", "field"),
    [
        ("export", set_at(("sensor", "acquisition_time_s"), None), "sensor.acquisition_time_s"),
        ("export", set_at(("robot", "limits", "velocity_rad_s", 0), 0),
         "robot.limits.velocity_rad_s"),
        ("export", set_at(("robot", "limits", "velocity_rad_s", 0), -1.0),
         "robot.limits.velocity_rad_s"),
        ("export", set_at(("robot", "limits", "velocity_rad_s", 0), 1e-300),
         "robot.limits.velocity_rad_s"),
        ("export", set_at(("robot", "limits", "jerk_rad_s3", 3), 0), "robot.limits.jerk_rad_s3"),
        ("export", set_at(("views", 0), 3), "views[0]"),
        ("export", set_at(("cell", "program", "trigger_output"), 9),
         "plan cell.program.trigger_output must be a standard digital I/O in 0..7"),
        ("export", lambda d: d["cell"]["program"].update(trigger_output=None,
                                                          trigger_script="a()\nhalt"),
         "plan cell.program.trigger_script must be one non-empty line"),
        ("export", set_at(("cell", "payload_kg"), -1), "plan cell.payload_kg"),
        ("export", set_at(("cell", "housing"), None), "plan cell.housing.position_m"),
        ("export", lambda d: None, "nested too deeply"),  # the file: 10^5 nested [
        ("check", set_at(("cycle_time",), [1]), "cycle_time"),
        ("check", set_at(("cycle_time", "total_s"), "23.1"), "cycle_time.total_s"),
        ("check", set_at(("object", "scale"), None), "object.scale"),
        ("render", set_at(("object", "scale"), None), "object.scale"),
        ("check", set_at(("robot", "sensor_mount", "quaternion"), [0, 0, 0, 0]),
         "robot.sensor_mount.quaternion"),
    ],
)
def test_a_malformed_plan_field_is_one_line_naming_it(
        command: str, change: Any, field: str, document: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    change(document)
    path = write(document, tmp_path)
    if field == "nested too deeply":
        path.write_text("[" * 100_000)
    options = {"export": ["--format", "urscript", "--out", str(tmp_path / "x.script")],
               "check": [], "render": ["--out", str(tmp_path / "x.gif")]}[command]
    plan = ["--plan", str(path)] if command == "render" else [str(path)]
    assert main([command, *plan, *options]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1 and "Traceback" not in error
    assert field in error
    if field == "nested too deeply":
        assert str(path) in error


def no_work(*args: Any, **kwargs: Any) -> None:
    raise AssertionError("the work started before the value was refused")


def test_a_sampling_step_finer_than_the_bound_is_refused_before_sampling(
        plan: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.kinematics.trajectory import TimedPlan

    monkeypatch.setattr(TimedPlan, "sample", no_work)
    # 1e-7 s over a 23 s cycle: 3.5 GiB before.
    with pytest.raises(SystemExit) as exit_:  # argparse's refusal
        main(["export", str(plan), "--format", "csv", "--out", str(tmp_path / "x.csv"),
              "--dt", "1e-7"])
    assert exit_.value.code == 2
    error = capsys.readouterr().err
    assert "--dt" in error and ">= 0.0001 s" in error


def test_a_path_resolution_finer_than_the_bound_is_refused_before_the_check(
        plan: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
        monkeypatch: pytest.MonkeyPatch) -> None:
    import vprobot.export.check

    monkeypatch.setattr(vprobot.export.check, "check_plan", no_work)
    # 1e-9 rad: 8.3 GiB before.
    config = tmp_path / "fine.yaml"
    config.write_text("kinematics:\n  path_max_joint_step_rad: 1.0e-9\n")
    assert main(["check", "--config", str(config), str(plan)]) == 2
    error = capsys.readouterr().err
    assert "kinematics.path_max_joint_step_rad must be >= 0.0001 rad" in error
    assert len(error.strip().splitlines()) == 1


def test_ros2_joint_names_stay_strings_that_yaml_would_read_as_numbers_or_booleans(
        document: dict[str, Any]) -> None:
    import dataclasses

    from vprobot.export.motion import plan_motion

    # Plain names a robot may have, which a bare YAML scalar would turn into 1, True, None, 1.5.
    names = ("1", "yes", "null", "1.5", "on", "joint_6")
    motion = plan_motion(document)
    motion = dataclasses.replace(motion, timed=dataclasses.replace(motion.timed,
                                                                   joint_names=names))
    goal = yaml.load(FORMATS["ros2"].write(motion, 0.1), Loader=SAFE_LOADER)
    assert goal["trajectory"]["joint_names"] == list(names)
    assert [entry["name"] for entry in goal["path_tolerance"]] == list(names)
