"""Tests of the up-front check that an object fits the cell, and of bounded seed searches."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh

import vprobot.coverage.ground_truth
import vprobot.episode.part_scene as part_scene
import vprobot.kinematics.arm as arm_module
from vprobot.cell.fit import check_fits, fit_limit, sensor_limit_m
from vprobot.cell.scene import Cell
from vprobot.config import Config
from vprobot.episode import PartScene
from vprobot.files.paths import CACHE_ENV_VAR
from vprobot.kinematics import RobotArm
from vprobot.parts.loading import load_mesh
from vprobot.planners.runner import plan_part

CONFIG = Config()
MOTORS = Path(vprobot.__file__).parent / "assets" / "motors"
MOTOR = MOTORS / "test" / "motor_000.stl"


def _box(path: Path, side: float) -> Path:
    trimesh.creation.box([side] * 3).export(path)
    return path


@pytest.fixture
def no_ground_truth(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty GT cache, and GT builders and cell construction that fail if reached."""
    cache = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV_VAR, str(cache))

    def forbidden(*args: object, **kwargs: object) -> None:
        raise AssertionError("reached past the fit check")

    monkeypatch.setattr(vprobot.coverage.ground_truth, "build_ground_truth", forbidden)
    monkeypatch.setattr(part_scene, "ground_truth", forbidden)
    monkeypatch.setattr(part_scene, "Cell", forbidden)
    return cache


def test_sensor_limit_is_the_frustum_edge_at_the_near_bound() -> None:
    # d = 0.47, near = 0.30, half of the smaller opening angle 12.5 degrees.
    expected = math.sqrt(0.47**2 + 0.30**2 - 2 * 0.47 * 0.30 * math.cos(math.radians(12.5)))
    assert sensor_limit_m(CONFIG) == pytest.approx(expected)
    assert fit_limit(CONFIG).radius_m == pytest.approx(0.1886, abs=1e-4)
    assert "sensor" in fit_limit(CONFIG).reason


@pytest.mark.parametrize(("name", "scale", "size", "hint"), [
    ("box", 1.0, r"0\.8 x 0\.8 x 0\.8 m, 0\.693 m", r"scale=0\.272 or less would make it fit"),
    ("motor", 4.0, r"0\.77 x 0\.532 x 0\.538 m, 0\.456 m", r"did you mean scale=1 \(file in m"),
])
def test_oversized_object_fails_before_ground_truth(tmp_path: Path, no_ground_truth: Path,
                                                    name: str, scale: float, size: str,
                                                    hint: str) -> None:
    # These used to hang: the arm's seed search never found a collision-free configuration.
    path = _box(tmp_path / "big.stl", 0.8) if name == "box" else MOTOR
    message = rf"{path.name} does not fit the cell: at scale={scale:g} it measures {size}"
    with pytest.raises(ValueError, match=rf"{message}.*allows 0\.189 m.*{hint}") as raised:
        PartScene.load(CONFIG, path, scale)
    assert "\n" not in str(raised.value)
    assert not no_ground_truth.exists() or not any(no_ground_truth.rglob("*"))


def test_millimetre_mesh_with_the_wrong_scale(tmp_path: Path, no_ground_truth: Path) -> None:
    motor = load_mesh(MOTOR).mesh.copy()
    motor.apply_scale(1000.0)
    path = tmp_path / "motor_mm.stl"
    motor.export(path)
    with pytest.raises(ValueError, match=r"motor_mm\.stl does not fit the cell: at scale=0\.01 "
                                         r".*did you mean scale=0\.001 \(file in millimetres\)\?$"):
        PartScene.load(CONFIG, path, 0.01)


def test_limit_is_the_bounding_sphere(tmp_path: Path) -> None:
    limit = fit_limit(CONFIG).radius_m
    side = 2.0 * limit / math.sqrt(3.0)
    check_fits(load_mesh(_box(tmp_path / "inside.stl", 0.999 * side)), CONFIG)
    with pytest.raises(ValueError, match=r"outside\.stl does not fit the cell"):
        check_fits(load_mesh(_box(tmp_path / "outside.stl", 1.001 * side)), CONFIG)


def test_bundled_motors_fit_with_margin() -> None:
    paths = sorted(MOTORS.glob("*/*.stl"))
    assert len(paths) == 25
    limit = fit_limit(CONFIG).radius_m
    for path in paths:
        loaded = load_mesh(path)
        check_fits(loaded, CONFIG)
        assert np.linalg.norm(loaded.mesh.vertices, axis=1).max() < 0.8 * limit, path.name


def test_restart_seeds_are_bounded_when_the_object_blocks_the_cell(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # Cell and arm construction come below the fit check: they must not hang on their own.
    draws = 0
    random_configuration = arm_module.random_configuration

    def counted(*args: object) -> np.ndarray:
        nonlocal draws
        draws += 1
        if draws > 100 * arm_module.MAX_SEED_DRAWS:
            raise AssertionError("unbounded seed search")
        return random_configuration(*args)

    monkeypatch.setattr(arm_module, "random_configuration", counted)
    arm = RobotArm(Cell(CONFIG, trimesh.creation.box([0.8] * 3)))
    assert draws == arm_module.MAX_SEED_DRAWS
    assert len(arm.restart_seeds) == 1
    np.testing.assert_array_equal(arm.restart_seeds[0], arm.joints.start)


def test_restart_seeds_of_a_fitting_object_are_unchanged() -> None:
    """The bound on the draws leaves a fitting object's seeds as they were: home, then the
    first collision-free draws of the configured generator (uniform within the limits, each
    joint at most half a turn out)."""
    arm = RobotArm(Cell(CONFIG, load_mesh(MOTOR).mesh))
    rng = np.random.default_rng(CONFIG.kinematics.seed)
    low, high = np.maximum(arm.joints.lower, -math.pi), np.minimum(arm.joints.upper, math.pi)
    expected = [arm.joints.start]
    for _ in range(arm_module.MAX_SEED_DRAWS):
        if len(expected) == CONFIG.kinematics.restarts:
            break
        q = rng.uniform(low, high)
        if not arm.collisions.in_collision(q):
            expected.append(q)
    assert len(expected) == CONFIG.kinematics.restarts
    np.testing.assert_array_equal(np.array(arm.restart_seeds), np.array(expected))


def test_cell_clearances_bind_for_unusual_placements(tmp_path: Path) -> None:
    low = dataclasses.replace(CONFIG, cell=dataclasses.replace(CONFIG.cell,
                                                               object_center_m=(0.45, 0.0, 0.15)))
    assert fit_limit(low).radius_m == pytest.approx(0.15)
    check_fits(load_mesh(MOTOR), low)
    with pytest.raises(ValueError, match=r"allows 0\.15 m.*through the floor"):
        check_fits(load_mesh(_box(tmp_path / "cube.stl", 0.2)), low)
    # Beside the UR10's column, below its base at (0, 0, 0.5).
    on_robot = dataclasses.replace(CONFIG, cell=dataclasses.replace(
        CONFIG.cell, object_center_m=(0.05, 0.0, 0.4)))
    with pytest.raises(ValueError, match=r"room for no object: .*robot base"):
        check_fits(load_mesh(MOTOR), on_robot)


def _millimetre_motor(path: Path) -> Path:
    motor = load_mesh(MOTOR).mesh.copy()
    motor.apply_scale(1000.0)
    motor.export(path)
    return path


@pytest.mark.parametrize(("option", "unit_hint", "fit_hint"), [
    ("scale", "use scale=0.001", "did you mean scale=0.001 (file in millimetres)?"),
    ("--scale", "use --scale 0.001", "did you mean --scale 0.001 (file in millimetres)?"),
    ("env.mesh_scale", "use env.mesh_scale=0.001",
     "did you mean env.mesh_scale=0.001 (file in millimetres)?"),
])
def test_unit_hints_name_the_scale_setting_the_caller_gave(
        tmp_path: Path, no_ground_truth: Path, option: str, unit_hint: str,
        fit_hint: str) -> None:
    path = _millimetre_motor(tmp_path / "motor_mm.stl")
    with pytest.raises(ValueError, match=re.escape(unit_hint)):
        PartScene.load(CONFIG, path, scale_option=option)
    with pytest.raises(ValueError, match=re.escape(fit_hint)):
        PartScene.load(CONFIG, path, 0.01, scale_option=option)


def test_plan_hints_name_the_scale_option(tmp_path: Path, no_ground_truth: Path) -> None:
    path = _millimetre_motor(tmp_path / "motor_mm.stl")
    with pytest.raises(ValueError, match=r"with --scale 1, .* use --scale 0\.001$"):
        plan_part(CONFIG, path)
    with pytest.raises(ValueError, match=r"at --scale 2 it .* did you mean --scale 1 \(file in "):
        plan_part(CONFIG, MOTOR, 2.0)
