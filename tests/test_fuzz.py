"""Fuzzing the env and the CLI (hypothesis, derandomised so that CI is repeatable): random
actions and valid configs never give NaN, infinity or an observation outside its space, and
malformed configs and meshes never give the user a traceback."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vprobot.cli import main
from vprobot.env.inspect_env import InspectEnv
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.rewards import REWARDS

FUZZ = settings(deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
ACTIONS = ["A_2S0R", "A_3S0R", "A_2S2R", "A_2S2R_lim", "A_3S2R", "A_3S2R_lim", "A_3C0R",
           "A_3C2R"]
REACH = ["reach", "--position", "0.45", "-0.47", "0.75", "--look-at", "0.45", "0", "0.75"]


@st.composite
def env_settings(draw: st.DrawFn) -> dict:
    carrier = draw(st.sampled_from(["robot", "free"]))
    reward = draw(st.sampled_from(list(REWARDS)))
    costs = ["cartesian", "paper"] if carrier == "free" and REWARDS[reward].uses_travel else [
        "joint_time", "joint_path", "cartesian", "paper"]
    return {
        "carrier": carrier,
        "reward": reward,
        "travel_cost": draw(st.sampled_from(costs)),
        "state": draw(st.sampled_from(["s_cov", "s_bin"])),
        "robot_state": draw(st.booleans()),
        "action": draw(st.sampled_from(ACTIONS)),
        "position_mapping": draw(st.sampled_from(["npk", "wpk"])),
        "unreachable": draw(st.sampled_from(["skip", "nearest"])),
        "initial_view": draw(st.sampled_from(["fixed", "random"])),
        "state_points": draw(st.integers(1, 3000)),
        "goal_only_step_cap": draw(st.integers(1, 4)),
        "unreachable_penalty": draw(st.floats(-2.0, 0.0)),
    }


def _finite(value: object) -> bool:
    if isinstance(value, dict):
        return all(_finite(item) for item in value.values())
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiub":
        return bool(np.all(np.isfinite(value)))
    if isinstance(value, float):
        return math.isfinite(value)
    return True


@settings(FUZZ, max_examples=25)
@given(settings_=env_settings(), seed=st.integers(0, 2**16),
       actions=st.lists(st.lists(st.sampled_from([-1.0, 1.0, 0.0, 0.3, -0.7]) | st.floats(-1, 1),
                                 min_size=5, max_size=5), min_size=1, max_size=6))
def test_env_never_leaves_its_spaces(settings_: dict, seed: int,
                                     actions: list[list[float]]) -> None:
    env = InspectEnv(parts="mesh", mesh=str(DEFAULT_MOTOR), resolution=(64, 45), **settings_)
    obs, info = env.reset(seed=seed)
    assert env.observation_space.contains(obs) and _finite(info)
    for raw in actions:
        action = np.array(raw[: env.action_space.shape[0]], dtype=np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        assert env.observation_space.contains(obs)
        assert math.isfinite(reward) and _finite(info)
        if terminated or truncated:
            break


def _one_line_or_success(argv: list[str], capsys: pytest.CaptureFixture,
                         allowed: tuple[int, ...]) -> None:
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert code in allowed, err
    if code == 2:
        assert len(err.strip().splitlines()) == 1, err


YAML_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 5) | st.floats(-3, 3) | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(
        st.sampled_from(["robot", "resolution", "fov_deg", "near_m", "far_m", "restarts",
                         "roll", "reward", "x"]), children, max_size=3),
    max_leaves=8)


@settings(FUZZ, max_examples=40)
@given(document=st.dictionaries(st.sampled_from(["cell", "sensor", "kinematics", "env", "junk"]),
                                YAML_VALUES, max_size=3) | YAML_VALUES,
       raw=st.booleans(), text=st.text(max_size=40))
def test_malformed_configs_are_one_line_errors(document: object, raw: bool, text: str,
                                               tmp_path: Path,
                                               capsys: pytest.CaptureFixture) -> None:
    config = tmp_path / "fuzz.yaml"
    config.write_text(text if raw else yaml.safe_dump(document))
    _one_line_or_success([*REACH, "--config", str(config)], capsys, (0, 1, 2))


def _binary_stl(triangles: np.ndarray) -> bytes:
    header = b"fuzz".ljust(80, b" ") + struct.pack("<I", len(triangles))
    body = b"".join(struct.pack("<12fH", 0.0, 0.0, 0.0, *triangle.ravel(), 0)
                    for triangle in triangles)
    return header + body


@st.composite
def bad_meshes(draw: st.DrawFn) -> tuple[str, bytes]:
    kind = draw(st.sampled_from(["bytes", "truncated", "nan", "one", "flat", "empty", "huge"]))
    if kind == "bytes":
        return ".stl", draw(st.binary(max_size=300))
    if kind == "empty":
        return draw(st.sampled_from([".stl", ".obj", ".ply"])), b""
    if kind == "truncated":
        data = DEFAULT_MOTOR.read_bytes()
        return ".stl", data[: draw(st.integers(1, 2000))]
    coordinates = st.floats(-0.1, 0.1, allow_nan=False)
    count = draw(st.integers(1, 6))
    triangles = np.array(draw(st.lists(st.lists(coordinates, min_size=9, max_size=9),
                                       min_size=count, max_size=count))).reshape(-1, 3, 3)
    if kind == "nan":
        triangles[0, 0, draw(st.integers(0, 2))] = np.nan
    elif kind == "flat":
        triangles[..., 2] = 0.0
    elif kind == "huge":
        triangles = triangles * 40.0
    return ".stl", _binary_stl(triangles)


@settings(FUZZ, max_examples=25)
@given(mesh=bad_meshes())
def test_malformed_meshes_are_one_line_errors(mesh: tuple[str, bytes], tmp_path: Path,
                                              capsys: pytest.CaptureFixture) -> None:
    suffix, data = mesh
    path = tmp_path / f"fuzz{suffix}"
    path.write_bytes(data)
    _one_line_or_success(["plan", "--no-summary", "--mesh", str(path), "--planner", "hrec",
                          "--carrier", "free",
                          "--out", str(tmp_path / "plan.json")], capsys, (0, 2))
