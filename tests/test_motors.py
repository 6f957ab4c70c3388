"""Tests of the seeded starter-motor generator."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh

from vprobot.motors import (
    MotorParameters,
    build_motor,
    generate_motors,
    motor_rng,
    sample_parameters,
)
from vprobot.parts import generated

# A handful of (seed, index) pairs: booleans take ~0.1 s per motor.
CASES = [(0, 0), (0, 7), (1, 3), (5, 11), (42, 2)]


@pytest.fixture(scope="module")
def motors() -> dict[tuple[int, int], tuple[MotorParameters, trimesh.Trimesh]]:
    built = {}
    for seed, index in CASES:
        params = sample_parameters(motor_rng(seed, index))
        built[seed, index] = (params, build_motor(params))
    return built


def test_sampled_parameters_satisfy_relations() -> None:
    for index in range(300):
        p = sample_parameters(motor_rng(3, index))
        assert 0.15 <= p.total_length_m <= 0.30
        assert p.solenoid_radius_m < p.housing_radius_m
        assert p.housing_radius_m < p.solenoid_height_m < p.housing_radius_m + p.solenoid_radius_m
        assert p.pinion_radius_m < p.nose_tip_radius_m <= p.nose_base_radius_m
        assert p.mounting_hole_pitch_radius_m + p.mounting_hole_radius_m < p.flange_radius_m
        assert p.mounting_hole_pitch_radius_m - p.mounting_hole_radius_m > p.housing_radius_m
        assert isinstance(p.bolt_count, int)


def test_parameters_are_deterministic_and_differ_across_seeds() -> None:
    assert sample_parameters(motor_rng(0, 4)) == sample_parameters(motor_rng(0, 4))
    drawn = [sample_parameters(motor_rng(seed, 0)) for seed in range(5)]
    assert len(set(drawn)) == 5
    assert len({p.housing_length_m for p in drawn}) == 5


def test_motors_are_closed_and_sized(motors: dict) -> None:
    for params, mesh in motors.values():
        assert mesh.is_watertight
        assert mesh.body_count == 1
        assert mesh.volume > 0
        assert 0.15 <= mesh.extents.max() <= 0.30
        assert mesh.extents[0] == pytest.approx(params.total_length_m, abs=1e-6)
        assert 2_000 <= len(mesh.faces) <= 20_000


def test_frame_convention(motors: dict) -> None:
    for params, mesh in motors.values():
        np.testing.assert_allclose(mesh.bounds.mean(axis=0), 0, atol=1e-9)
        assert np.argmax(mesh.extents) == 0
        # The pinion face is the +x end and lies on the motor axis.
        front = mesh.vertices[np.isclose(mesh.vertices[:, 0], mesh.bounds[1, 0])]
        axis_y, axis_z = front[:, 1:].mean(axis=0)
        assert axis_y == pytest.approx(0, abs=1e-6)
        # The solenoid's top is the highest point, so it sits on +z.
        top = params.solenoid_height_m + params.solenoid_radius_m
        assert mesh.bounds[1, 2] - axis_z == pytest.approx(top, abs=1e-6)


def test_build_is_deterministic(motors: dict) -> None:
    _, mesh = motors[CASES[0]]
    again = build_motor(sample_parameters(motor_rng(*CASES[0])))
    np.testing.assert_array_equal(again.vertices, mesh.vertices)
    np.testing.assert_array_equal(again.faces, mesh.faces)


def test_motors_differ_across_seeds(motors: dict) -> None:
    volumes = [mesh.volume for _, mesh in motors.values()]
    assert len({round(v, 9) for v in volumes}) == len(volumes)
    assert max(volumes) > 1.2 * min(volumes)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("housing_length_m", 1.0),
        ("solenoid_radius_m", "housing_radius_m"),
        ("pinion_radius_m", "nose_tip_radius_m"),
        ("flange_radius_m", "mounting_hole_pitch_radius_m"),
        ("solenoid_height_m", 0.0),
        ("bolt_count", 2.5),
        ("terminal_count", 7),
    ],
)
def test_invalid_parameters_name_the_field(field: str, value: float | str) -> None:
    params = sample_parameters(motor_rng(0, 0))
    if isinstance(value, str):
        value = getattr(params, value)
    with pytest.raises(ValueError, match=rf"^{field}=.*(allowed range|must be an integer)"):
        dataclasses.replace(params, **{field: value})


def test_generate_motors_writes_stl_and_json(tmp_path: Path) -> None:
    paths = generate_motors(2, seed=9, out_dir=tmp_path / "set", progress=False)
    # Named by their set's seed, as part instances are, and as episode lists name them.
    assert [p.name for p in paths] == ["motor_9_000.stl", "motor_9_001.stl"]
    assert paths[1].name == generated.motor_object(9, 1).removeprefix(generated.PREFIX)
    assert sorted(p.name for p in (tmp_path / "set").iterdir()) == [
        "motor_9_000.json",
        "motor_9_000.stl",
        "motor_9_001.json",
        "motor_9_001.stl",
    ]
    meta = json.loads((tmp_path / "set" / "motor_9_001.json").read_text())
    assert (meta["seed"], meta["index"]) == (9, 1)
    params = MotorParameters(**meta["parameters"])
    assert params == sample_parameters(motor_rng(9, 1))
    mesh = trimesh.load(paths[1])
    assert mesh.is_watertight
    assert mesh.extents[0] == pytest.approx(params.total_length_m, abs=1e-6)


def test_motor_i_does_not_depend_on_count(tmp_path: Path) -> None:
    one = generate_motors(1, seed=4, out_dir=tmp_path / "one", progress=False)
    two = generate_motors(2, seed=4, out_dir=tmp_path / "two", progress=False)
    assert one[0].read_bytes() == two[0].read_bytes()


@pytest.mark.parametrize(("count", "seed"), [(0, 0), (-3, 0), (1, -1)])
def test_generate_motors_rejects_bad_arguments(tmp_path: Path, count: int, seed: int) -> None:
    with pytest.raises(ValueError, match=str(count if count < 1 else seed)):
        generate_motors(count, seed=seed, out_dir=tmp_path, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_generate_bundled_rewrites_the_committed_motors_byte_for_byte(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from vprobot.cli import main
    from vprobot.files.paths import MOTORS_DIR

    assert main(["motors", "generate", "--bundled", "--out", str(tmp_path)]) == 0
    written = sorted(path.relative_to(tmp_path) for path in tmp_path.rglob("motor_*"))
    committed = sorted(path.relative_to(MOTORS_DIR) for path in MOTORS_DIR.rglob("motor_*"))
    assert written == committed and len(written) == 2 * (20 + 5)
    assert all((tmp_path / name).read_bytes() == (MOTORS_DIR / name).read_bytes()
               for name in written)
    assert capsys.readouterr().out == f"wrote 25 motors to {tmp_path}\n"


@pytest.mark.parametrize(("argv", "message"), [
    (["--bundled", "--count", "3"], "--count and --seed are not allowed with it"),
    (["--bundled", "--seed", "0"], "--count and --seed are not allowed with it"),
    (["--count", "3"], "--count and --out are required (or --bundled)"),
    (["--out", "m"], "--count and --out are required (or --bundled)"),
])
def test_generate_refuses_mixed_or_missing_options_in_one_line(
        argv: list[str], message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from vprobot.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["motors", "generate", *argv]) == 2
    error = capsys.readouterr().err
    assert error.startswith("vprobot motors generate: error: ") and error.endswith(
        f"{message}\n") and error.count("\n") == 1
    assert list(tmp_path.iterdir()) == []
