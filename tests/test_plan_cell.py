"""The plan's cell: `vprobot check` rebuilds the cell a plan was made in from its `cell` block and
reports the robot's least clearance to each object; `evaluate` rows the least clearance per
episode. Distances are held to references computed without MuJoCo's distance query where one
exists (box to box by a bounded least-squares solve), else to a measurement at every
configuration."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest
import trimesh
import yaml
from scipy.optimize import minimize

from vprobot.cell.check import (
    CLEARANCE_RESOLUTION_M,
    clearances,
    environment_geoms,
    placed_part,
)
from vprobot.cell.scene import HOUSING_GEOM, Cell
from vprobot.cli import main
from vprobot.config import Config, load_config, replace
from vprobot.config.cell import StaticObject, rotation_rpy_deg, rpy_rotation
from vprobot.episode import PartScene, seeded_episode
from vprobot.episode.clearances import episode_clearances
from vprobot.evaluation import _append_row, episode_row, finished_rows
from vprobot.export.check import _cell, check_plan
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.kinematics.motion_planner import densify
from vprobot.plan import read_plan
from vprobot.planners.runner import run

CELL = {
    "robot": "ur10",
    "robot_base_position_m": [0.0, 0.0, 0.8],
    "robot_stand": False,
    "start_joints_rad": [0.0, -1.8, 1.8, -1.57, -1.57, 0.3],
    "part": {"mesh": str(DEFAULT_MOTOR), "position_m": [0.75, 0.0, 0.8872],
             "rpy_deg": [0.0, 0.0, 30.0]},
    "fixture": "none",
    "static_objects": [
        {"name": "table", "shape": "box", "size_m": [1.6, 1.0, 0.05],
         "position_m": [0.4, 0.0, 0.775]},
        {"name": "plate", "shape": "box", "size_m": [0.3, 0.2, 0.02],
         "position_m": [0.75, 0.0, 0.81]},
        {"name": "post", "shape": "cylinder", "radius_m": 0.03, "length_m": 0.4,
         "position_m": [1.1, 0.5, 1.0], "rpy_deg": [10.0, 0.0, 0.0]},
    ],
    "safety": {"clearance_m": 0.012, "part_clearance_m": 0.015, "joint_limit_margin_deg": 3.0,
               "speed_scale": 0.8},
    "program": {"trigger_output": None, "trigger_script": "sensor_trigger()", "done_input": 2},
}
"""A UR10 on a table, the part turned on a plate, a post, margins and a speed scale of its own."""
SENSOR = {"mass_kg": 1.1,
          "housing": {"shape": "box", "size_m": [0.18, 0.07, 0.09],
                      "position_m": [0.0, 0.005, -0.045], "rpy_deg": [0.0, 5.0, 90.0]}}


WALL = {"name": "wall", "shape": "mesh", "mesh": "wall.stl", "scale": 0.001,
        "position_m": [0.2, -0.8, 0.8], "rpy_deg": [0.0, 0.0, 15.0]}
"""A wall of the cell as a mesh in millimetres, named relative to the config file."""


@pytest.fixture(scope="module")
def cell_config(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("cell")
    trimesh.creation.box((1200.0, 20.0, 1000.0)).export(folder / "wall.stl")
    path = folder / "cell.yaml"
    cell = {**CELL, "static_objects": [*CELL["static_objects"], WALL]}
    path.write_text(yaml.safe_dump({"cell": cell, "sensor": SENSOR}))
    return path


@pytest.fixture(scope="module")
def cell_plan(cell_config: Path) -> Path:
    """A 3-view nbv plan made in `CELL`."""
    path = cell_config.parent / "plan.json"
    assert main(["plan", "--no-summary", "--config", str(cell_config), "--planner", "nbv",
                 "--stop", "views:3",
                 "--no-timing", "--out", str(path)]) == 0
    return path


@pytest.fixture
def document(cell_plan: Path) -> dict[str, Any]:
    return json.loads(cell_plan.read_text())


def write(document: dict[str, Any], folder: Path) -> Path:
    path = folder / "changed.json"
    path.write_text(json.dumps(document))
    return path


def test_check_rebuilds_the_cell_the_plan_was_made_in(cell_config: Path, cell_plan: Path) -> None:
    """The cell rebuilt from the plan alone (under the default config) is the planned one:
    the same settings, housing and payload, and the same compiled geoms, margins and
    narrowed joint ranges."""
    planned, mesh = placed_part(load_config(cell_config))
    document = read_plan(cell_plan)
    rebuilt, _ = _cell(Config(), document, cell_plan)
    settings = rebuilt.config.cell
    # The plan states the base pose itself; the cell file left the robot's default yaw, tilt.
    assert dataclasses.replace(settings, robot_base_yaw_deg=None,
                               robot_base_tilt_deg=None) == planned.cell
    housing = rebuilt.config.sensor.housing
    assert dataclasses.replace(housing, rpy_deg=planned.sensor.housing.rpy_deg) == (
        planned.sensor.housing)
    assert housing.rpy_deg == pytest.approx(planned.sensor.housing.rpy_deg, abs=1e-9)
    assert rebuilt.config.sensor.mass_kg == planned.sensor.mass_kg == 1.1
    original = Cell(planned, mesh.mesh).model
    model = rebuilt.model
    assert model.ngeom == original.ngeom
    assert [model.geom(g).name for g in range(model.ngeom)] == [
        original.geom(g).name for g in range(original.ngeom)]
    for field in ("geom_size", "geom_pos", "geom_quat", "geom_margin", "jnt_range",
                  "body_pos", "body_quat"):
        np.testing.assert_allclose(getattr(model, field), getattr(original, field), atol=1e-9,
                                   err_msg=field)


def test_check_of_a_plan_in_its_cell_reports_each_objects_clearance_above_its_margin(
        cell_plan: Path, capsys: pytest.CaptureFixture) -> None:
    check = check_plan(Config(), cell_plan)
    assert check.holds, check.failures
    assert {item.name: item.margin_m for item in check.clearances} == {
        "table": 0.012, "plate": 0.012, "post": 0.012, "wall": 0.012, "the part": 0.015}
    assert all(item.distance_m >= item.margin_m for item in check.clearances)
    assert main(["check", str(cell_plan)]) == 0
    out = capsys.readouterr().out
    for item in check.clearances:
        assert (f"    {item.name}: {item.distance_m * 1e3:.1f} mm, margin "
                f"{item.margin_m * 1e3:g} mm, ok") in out


def test_a_plan_moved_with_its_meshes_checks_from_its_new_folder(
        cell_plan: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """The wall's mesh is recorded absolute; moved away, it is found beside the plan."""
    document = json.loads(cell_plan.read_text())
    (wall,) = [entry for entry in document["cell"]["settings"]["static_objects"]
               if entry["name"] == "wall"]
    assert Path(wall["mesh"]) == cell_plan.parent / "wall.stl"
    wall["mesh"] = str(tmp_path / "gone" / "wall.stl")
    (tmp_path / "wall.stl").write_bytes((cell_plan.parent / "wall.stl").read_bytes())
    assert main(["check", str(write(document, tmp_path))]) == 0
    assert re.search(r"    wall: [\d.]+ mm, margin 12 mm, ok", capsys.readouterr().out)
    (tmp_path / "wall.stl").unlink()
    assert main(["check", str(write(document, tmp_path))]) == 2
    error = capsys.readouterr().err
    assert "static object mesh" in error and "wall.stl not found" in error


def test_check_fails_naming_a_static_object_within_its_margin(
        document: dict[str, Any], cell_plan: Path, tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    """A box added to the plan's cell 5 mm in front of the housing at the first view: the check
    rebuilds it, reports it closer than its margin of 12 mm, and fails."""
    cell, _ = _cell(Config(), document, cell_plan)
    data = cell.make_data()
    data.qpos[:] = document["views"][0]["joints"]
    mujoco.mj_kinematics(cell.model, data)
    housing = cell.model.geom(HOUSING_GEOM).id
    centre, frame = data.geom_xpos[housing], data.geom_xmat[housing].reshape(3, 3)
    half = cell.model.geom_size[housing]
    # The housing's face towards the viewing direction: along its axis most aligned with it.
    viewing = data.xmat[cell.sensor_body_id].reshape(3, 3)[:, 2]
    axis = int(np.argmax(np.abs(frame.T @ viewing)))
    direction = frame[:, axis] * np.sign(frame[:, axis] @ viewing)
    guard_centre = centre + direction * (half[axis] + 0.005 + 0.01)
    document["cell"]["settings"]["static_objects"].append(
        {"name": "guard", "shape": "box", "size_m": [0.02, 0.02, 0.02],
         "position_m": guard_centre.tolist(),
         "rpy_deg": list(rotation_rpy_deg(frame))})
    path = write(document, tmp_path)
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    found = re.search(r"    guard: (-?[\d.]+) mm, margin 12 mm, FAILS", out)
    assert found is not None, out
    assert float(found[1]) <= 5.0 + 1e-3
    assert re.search(r"clearance: the robot comes -?[\d.]+ mm from guard, within its margin of "
                     r"12 mm", out)
    assert "check FAILED" in out


def test_check_holds_the_samples_to_the_cells_narrowed_joint_limits_and_scaled_speed(
        document: dict[str, Any], cell_plan: Path, tmp_path: Path) -> None:
    """The replay's joint limits are the robot's less the plan's joint-limit margin (3 deg),
    as the plan states them; a plan whose settings give others, or a slower speed scale than
    it was timed at, fails."""
    cell, _ = _cell(Config(), document, cell_plan)
    full = Cell(replace(Config(), "cell", safety={"joint_limit_margin_deg": 0.0})).joints
    stated = document["cell"]["joint_limits_rad"]
    np.testing.assert_allclose(cell.joints.lower, full.lower + np.deg2rad(3.0), atol=1e-12)
    np.testing.assert_allclose(cell.joints.upper, full.upper - np.deg2rad(3.0), atol=1e-12)
    np.testing.assert_allclose(stated["lower"], cell.joints.lower, atol=1e-12)
    np.testing.assert_allclose(stated["upper"], cell.joints.upper, atol=1e-12)
    wider = json.loads(json.dumps(document))
    wider["cell"]["settings"]["safety"]["joint_limit_margin_deg"] = 10.0
    failures = check_plan(Config(), write(wider, tmp_path)).failures
    assert any(line.startswith("joint limits: the plan states cell.joint_limits_rad")
               for line in failures), failures
    slower = json.loads(json.dumps(document))
    slower["cell"]["settings"]["safety"]["speed_scale"] = 0.4
    failures = check_plan(Config(), write(slower, tmp_path)).failures
    assert any("timed under robot.limits.velocity_rad_s above the robot's" in line
               for line in failures), failures


def test_a_plan_without_a_cell_block_checks_in_the_default_cell(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Plans written before the `cell` block replay in the config's cell: the default's
    fixture and the part are measured."""
    path = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--planner", "nbv", "--stop", "views:2", "--no-timing",
                 "--out",
                 str(path)]) == 0
    document = json.loads(path.read_text())
    del document["cell"]
    old = write(document, tmp_path)
    capsys.readouterr()
    assert main(["check", str(old)]) == 0
    out = capsys.readouterr().out
    assert "check holds" in out
    for name in ("fixture_plate", "pedestal", "the part"):
        assert re.search(rf"    {name}: [\d.]+ mm, margin 10 mm, ok", out)


def box_distance(centre_a: np.ndarray, frame_a: np.ndarray, half_a: np.ndarray,
                 centre_b: np.ndarray, frame_b: np.ndarray, half_b: np.ndarray) -> float:
    """The distance between two disjoint boxes: the least |p - q| over a point of each, a
    convex least-squares problem in the boxes' own coordinates."""

    def gap(u: np.ndarray) -> tuple[float, np.ndarray]:
        difference = centre_a + frame_a @ u[:3] - centre_b - frame_b @ u[3:]
        return float(difference @ difference), np.concatenate(
            [2 * frame_a.T @ difference, -2 * frame_b.T @ difference])

    bounds = [(-h, h) for h in (*half_a, *half_b)]
    result = minimize(gap, np.zeros(6), jac=True, bounds=bounds, method="L-BFGS-B",
                      options={"ftol": 1e-15, "gtol": 1e-12, "maxiter": 1000})
    return float(np.sqrt(result.fun))


def test_the_clearance_to_a_box_is_the_boxes_distance_from_the_sensor_housing() -> None:
    """A turned box 30 mm in front of the housing, turned too: the reported clearance at that
    configuration is the distance between the two boxes, computed without MuJoCo."""
    config = Config()
    empty = Cell(config)
    data = empty.make_data()
    q = empty.joints.start
    data.qpos[:] = q
    mujoco.mj_kinematics(empty.model, data)
    sensor = data.xpos[empty.sensor_body_id].copy()
    frame = data.xmat[empty.sensor_body_id].reshape(3, 3).copy()
    housing = config.sensor.housing
    centre_a = sensor + frame @ np.array(housing.position_m)
    half_a = np.array(housing.size_m) / 2
    turned = rpy_rotation((25.0, -15.0, 40.0))
    centre_b = sensor + frame @ np.array([0.03, -0.01, 0.06])
    half_b = np.array([0.02, 0.015, 0.01])
    probe = StaticObject(name="probe", shape="box", size_m=tuple(2 * half_b),
                         position_m=tuple(centre_b), rpy_deg=rotation_rpy_deg(turned))
    cell = Cell(replace(config, "cell", static_objects=[dataclasses.asdict(probe)]))
    data = cell.make_data()
    reported = {item.name: item.distance_m for item in clearances(cell, data, q[None])}
    expected = box_distance(centre_a, frame, half_a, centre_b, turned, half_b)
    assert 0.01 < expected < 0.06
    assert reported["probe"] == pytest.approx(expected, abs=1e-6)


def every_configuration(cell: Cell, data: mujoco.MjData, path: np.ndarray) -> dict[str, float]:
    """The least distance to each object measured at every configuration of `path`."""
    model = cell.model
    moving = [g for g in cell.robot_geom_ids if model.geom_bodyid[g] != cell.base_body_id]
    least: dict[str, float] = {}
    for q in path:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for name, geoms in environment_geoms(cell).items():
            for geom in geoms:
                for robot_geom in moving:
                    distance = mujoco.mj_geomDistance(model, data, robot_geom, geom, 1.0, None)
                    least[name] = min(least.get(name, 1.0), distance)
    return least


def test_clearances_along_a_path_skip_only_what_cannot_come_closer(
        document: dict[str, Any], cell_plan: Path) -> None:
    """Along the plan's densified moves the least distances skipped to are those measured at
    every configuration, to within the resolution (never below them)."""
    cell, rotation = _cell(Config(), document, cell_plan)
    data = cell.make_data()
    cell.place_object(data, rotation)
    moves = [view["waypoints"] for view in document["views"] if view["waypoints"]]
    path = np.concatenate([densify(np.array(move), 0.02) for move in
                           [*moves, document["return"]["waypoints"]]])
    fast = {item.name: item.distance_m for item in clearances(cell, data, path)}
    slow = every_configuration(cell, data, path)
    assert fast.keys() == slow.keys()
    for name, distance in slow.items():
        assert distance - 1e-12 <= fast[name] <= distance + CLEARANCE_RESOLUTION_M, name


def test_an_episode_row_has_its_least_clearance_and_whether_every_margin_held(
        tmp_path: Path) -> None:
    config = Config()
    scene = PartScene.load(config, DEFAULT_MOTOR)
    result = run(config, scene, "nbv", seeded_episode(config.env, DEFAULT_MOTOR, 0),
                 stop="views:2")
    row = episode_row(0, result)
    record = result.record
    moves = [view.waypoints for view in record.views if view.waypoints is not None]
    path = np.concatenate([densify(move, config.kinematics.path_max_joint_step_rad)
                           for move in [*moves, record.return_waypoints]])
    data = scene.cell.make_data()
    scene.cell.place_object(data, record.object_pose.rotation)
    least = min(every_configuration(scene.cell, data, path).values())
    assert least * 1e3 <= row["min_clearance_mm"] <= (least + CLEARANCE_RESOLUTION_M) * 1e3
    assert row["clearance_held"] is True and row["min_clearance_mm"] >= 10.0
    assert result.clearances == episode_clearances(record, scene.cell)
    table = tmp_path / "rows.csv"
    _append_row(table, row)
    (read,) = finished_rows(table)
    assert read["min_clearance_mm"] == pytest.approx(row["min_clearance_mm"])
    assert read["clearance_held"] is True
    free = dataclasses.replace(result, carrier="free", clearances=None)
    assert (episode_row(0, free)["min_clearance_mm"], episode_row(0, free)["clearance_held"]) == (
        None, None)


@pytest.mark.parametrize(("change", "message"), [
    (lambda cell: cell["settings"]["safety"].update(clearance_m=-1),
     "plan cell.settings: cell.safety.clearance_m must lie in [0, 0.2] m, got -1"),
    (lambda cell: cell.update(settings=[1]), "plan cell.settings must be an object, got [1]"),
    (lambda cell: cell["settings"].update(bogus=1),
     "plan cell.settings: unknown key 'bogus' in section 'cell'"),
    (lambda cell: cell["housing"].update(quaternion_wxyz=[0, 0, 0, 0]),
     "plan cell.housing.quaternion_wxyz must be a non-zero quaternion"),
])
def test_a_malformed_cell_block_is_one_line_naming_its_field(
        change: Any, message: str, document: dict[str, Any], tmp_path: Path,
        capsys: pytest.CaptureFixture) -> None:
    change(document["cell"])
    assert main(["check", str(write(document, tmp_path))]) == 2
    error = capsys.readouterr().err
    assert len(error.strip().splitlines()) == 1 and message in error
