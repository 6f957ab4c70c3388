"""Cell files: the bundled ones, `--cell`, the worked example of docs/your-cell.md end to end,
and a cell file that fails its own check (one line naming the file, the key and the fault)."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from vprobot.cli import main
from vprobot.cli.common import config_of
from vprobot.config import CellConfig, Config, SensorConfig, load_config, sensor_preset
from vprobot.config.cell import PartConfig, ProgramConfig, SafetyConfig, Solid, with_cell_file
from vprobot.files.paths import CELLS_DIR, CONFIGS_DIR, DEFAULT_CONFIG, available_cells
from vprobot.files.schema import from_mapping, read_yaml
from vprobot.parts.loading import load_mesh

EXAMPLE = CELLS_DIR / "ur10_phoxi_s_example.yaml"


def _cell(name: str | Path) -> Config:
    return from_mapping(Config, with_cell_file({"cell": str(name)}, None))


def _field_names(cls: type) -> set[str]:
    return {field.name for field in dataclasses.fields(cls)}


@pytest.mark.parametrize("name", available_cells())
def test_every_bundled_cell_loads(name: str) -> None:
    assert isinstance(_cell(name).cell, CellConfig)


def test_the_bundled_cells_are_there() -> None:
    assert {"default", "realistic", "ur10_phoxi_s_example"} <= set(available_cells())


def test_default_cell_file_lists_every_key_at_the_schema_default() -> None:
    written = read_yaml(CELLS_DIR / "default.yaml")
    assert set(written["cell"]) == _field_names(CellConfig)
    assert set(written["cell"]["safety"]) == _field_names(SafetyConfig)
    assert set(written["cell"]["program"]) == _field_names(ProgramConfig)
    assert set(written["sensor"]) == _field_names(SensorConfig)
    assert set(written["sensor"]["housing"]) == _field_names(Solid)
    config = _cell("default")
    assert config.cell == CellConfig()
    assert config.sensor == SensorConfig()
    # configs/default.yaml holds the same cell and sensor.
    default = load_config(DEFAULT_CONFIG)
    assert (default.cell, default.sensor) == (config.cell, config.sensor)


def test_realistic_cell_is_the_zivid_at_a_quarter_resolution_in_the_default_cell() -> None:
    expected = dataclasses.replace(sensor_preset("zivid2plus_mr60"), resolution=(612, 512))
    for config in (_cell("realistic"), load_config(CONFIGS_DIR / "cell_real.yaml")):
        assert config.cell == CellConfig()
        assert config.sensor == expected


def test_example_part_rests_on_its_plate() -> None:
    """The part's lowest point (its mesh placed at the file's pose) meets the plate's top."""
    cell = _cell(EXAMPLE).cell
    part = cell.part
    assert isinstance(part, PartConfig) and cell.fixture == "none"
    assert not Path(read_yaml(EXAMPLE)["cell"]["part"]["mesh"]).is_absolute()
    mesh = load_mesh(part.mesh, part.scale, "cell.part.scale").mesh
    lowest = float((mesh.vertices @ part.rotation.T + part.position_m)[:, 2].min())
    plate = next(item for item in cell.static_objects if item.name == "plate")
    assert plate.size_m is not None
    assert lowest == pytest.approx(plate.position_m[2] + plate.size_m[2] / 2, abs=1e-4)
    assert plate.size_m[:2] == (0.3, 0.2)


def _args(**options: Any) -> argparse.Namespace:
    given = {"config": None, "cell": None, "robot": None, "sensor": None, "sensing": None}
    return argparse.Namespace(**{**given, **options})


def test_cell_option_replaces_cell_and_sensor_before_the_sensor_option() -> None:
    example = read_yaml(EXAMPLE)
    config = config_of(_args(cell="ur10_phoxi_s_example"))
    assert [item.name for item in config.cell.static_objects] == ["table", "plate", "wall"]
    assert config.sensor.housing == sensor_preset("phoxi_s").housing
    assert config.sensor.mount_position_m == tuple(example["sensor"]["mount_position_m"])
    swapped = config_of(_args(cell=str(EXAMPLE), sensor="paper"))
    assert swapped.sensor.resolution == sensor_preset("paper").resolution
    assert swapped.sensor.mount_position_m == config.sensor.mount_position_m
    assert swapped.cell == config.cell


def test_worked_example_plans_exports_and_checks_from_its_file_alone(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)  # the part's mesh is found relative to the cell file
    plan, picture = tmp_path / "plan.json", tmp_path / "cell.png"
    assert main(["plan", "--no-summary", "--cell", str(EXAMPLE), "--planner", "nbv", "--stop",
                 "views:3",
                 "--out", str(plan), "--picture", str(picture)]) == 0
    document = json.loads(plan.read_text())
    example = read_yaml(EXAMPLE)["cell"]
    np.testing.assert_allclose(document["object"]["position"], example["part"]["position_m"])
    assert [item["name"] for item in document["cell"]["static_objects"]] == [
        item["name"] for item in example["static_objects"]]
    assert document["cell"]["payload_kg"] == read_yaml(EXAMPLE)["sensor"]["mass_kg"]
    assert picture.read_bytes().startswith(b"\x89PNG")
    for form, name in (("urscript", "program.script"), ("ros2", "goal.yaml")):
        assert main(["export", str(plan), "--format", form, "--out", str(tmp_path / name)]) == 0
        assert (tmp_path / name).stat().st_size > 0
    capsys.readouterr()
    assert main(["check", str(plan)]) == 0
    report = capsys.readouterr().out
    for name in ("table", "plate", "wall", "the part"):
        assert any(line.strip().startswith(f"{name}:") and line.rstrip().endswith("ok")
                   for line in report.splitlines())


def _broken(tmp_path: Path, change: Any) -> Path:
    """The worked example with `change` applied to its mapping, written into `tmp_path`."""
    data = yaml.safe_load(EXAMPLE.read_text())
    data["cell"]["part"]["mesh"] = str((EXAMPLE.parent / data["cell"]["part"]["mesh"]).resolve())
    change(data)
    path = tmp_path / "my_cell.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _error_line(stderr: str) -> str:
    """The one error line of `stderr`, after any progress bar (drawn with carriage returns)."""
    assert stderr.count("error:") == 1 and stderr.endswith("\n")
    return stderr.rstrip("\n").split("\n")[-1].split("\r")[-1]


BAD_CELLS = {
    "an object into the base": (
        lambda d: d["cell"]["static_objects"].append(
            {"name": "post", "shape": "cylinder", "radius_m": 0.05, "length_m": 0.4,
             "position_m": [0.0, 0.0, 1.0]}),
        ("cell.static_objects", "post", "into the robot's base")),
    "a part sunk into its plate": (
        lambda d: d["cell"]["static_objects"][1].update(position_m=[0.75, 0.0, 0.83]),
        ("cell.static_objects", "plate", "into the part")),
    "a negative margin": (
        lambda d: d["cell"]["safety"].update(clearance_m=-0.01),
        ("cell.safety.clearance_m", "must lie in [0, 0.2]", "-0.01")),
    "an unknown key": (
        lambda d: d["cell"]["safety"].update(clearence_m=0.01),
        ("'clearence_m'", "cell.safety", "allowed keys")),
    "a housing into the arm at the start pose": (
        lambda d: d["sensor"].update(housing={"shape": "box", "size_m": [0.3, 0.3, 1.2],
                                              "position_m": [0.0, 0.0, -0.6]}),
        ("cell.start_joints_rad", "the sensor housing collides")),
}


@pytest.mark.parametrize("case", sorted(BAD_CELLS))
def test_a_bad_cell_file_is_one_line_naming_file_key_and_fault(
        case: str, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    change, words = BAD_CELLS[case]
    path = _broken(tmp_path, change)
    out = tmp_path / "plan.json"
    assert main(["plan", "--no-summary", "--cell", str(path), "--planner", "nbv", "--stop",
                 "views:1",
                 "--out", str(out)]) == 2
    error = _error_line(capsys.readouterr().err)
    assert error.startswith("vprobot plan: error: ") and str(path) in error
    for word in words:
        assert word in error
    assert not out.exists()


def test_a_cell_error_names_the_config_file_that_holds_the_cell(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    cell_path = _broken(tmp_path, BAD_CELLS["a part sunk into its plate"][0])
    config = tmp_path / "config.yaml"
    config.write_text(f"cell: {cell_path}\n")
    assert main(["plan", "--no-summary", "--config", str(config), "--planner", "nbv", "--stop",
                 "views:1",
                 "--out", str(tmp_path / "plan.json")]) == 2
    assert _error_line(capsys.readouterr().err).startswith(
        f"vprobot plan: error: {cell_path}: cell.static_objects: plate")
    inline = tmp_path / "inline.yaml"
    inline.write_text(yaml.safe_dump(read_yaml(cell_path)))
    assert main(["plan", "--no-summary", "--config", str(inline), "--planner", "nbv", "--stop",
                 "views:1",
                 "--out", str(tmp_path / "plan.json")]) == 2
    assert _error_line(capsys.readouterr().err).startswith(
        f"vprobot plan: error: {inline}: cell.static_objects: plate")


def test_unknown_cell_is_one_line_listing_the_bundled_cells(
        capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    assert main(["plan", "--cell", "no_such_cell", "--out", str(tmp_path / "plan.json")]) == 2
    error = _error_line(capsys.readouterr().err)
    assert "--cell" in error and "no_such_cell" in error
    assert all(name in error for name in available_cells())
