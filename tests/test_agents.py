"""Agents: feature extractors against their published sizes, training smoke runs (SAC and PPO,
Box and Dict observations), resume after kill -9, the model-free premise, profiles, curves."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
import torch
import trimesh
import yaml
from helpers import TINY_TRAINING, SmokeRuns
from PIL import Image
from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer

from vprobot.agents.encoders import ENCODERS
from vprobot.agents.extractors.pcn import PCNExtractor
from vprobot.agents.extractors.pointnet import InputTransform, PointNetExtractor
from vprobot.agents.extractors.sphere_map import SphereMapExtractor
from vprobot.config import ConfigError, replace
from vprobot.files.atomic import save_figure
from vprobot.files.paths import CONFIGS_DIR, MOTORS_DIR
from vprobot.training import curves as curves_module
from vprobot.training.callbacks import (
    ResumableCheckpoint,
    SharedEpisodeEvaluation,
    count_lines,
    load_buffer,
    save_buffer,
)
from vprobot.training.curves import plot_curves, read_monitor
from vprobot.training.train import (
    buffer_memory,
    build_model,
    config_document,
    make_vec_env,
    monitor_file,
    profile_config,
    train,
)

PROFILES = CONFIGS_DIR / "agents"
TINY = list(TINY_TRAINING)
BOX = gym.spaces.Box(-4, 4, (128, 3), np.float32)
DICT = gym.spaces.Dict({"points": gym.spaces.Box(-4, 4, (128, 4), np.float32),
                        "robot": gym.spaces.Box(-8, 8, (15,), np.float32)})
ACTION = gym.spaces.Box(-1, 1, (5,), np.float32)


def tiny_extractor(name: str, space: gym.Space):
    return (SphereMapExtractor(space) if name == "sphere"
            else ENCODERS[name].network(space, scale=0.05))


@pytest.mark.parametrize("name", [name for name, encoder in ENCODERS.items()
                                  if "sac" in encoder.algorithms])
@pytest.mark.parametrize("space", [BOX, DICT], ids=["box", "dict"])
def test_extractors_give_features_and_gradients(name: str, space: gym.Space) -> None:
    extractor = tiny_extractor(name, space)
    batch = {key: torch.as_tensor(np.stack([sub.sample() for _ in range(5)]))
             for key, sub in space.spaces.items()} if isinstance(space, gym.spaces.Dict) else (
        torch.as_tensor(np.stack([space.sample() for _ in range(5)])))
    features = extractor(batch)
    assert features.shape == (5, extractor.features_dim)
    assert torch.isfinite(features).all()
    features.square().sum().backward()
    for name_, parameter in extractor.named_parameters():
        assert parameter.grad is not None, name_
        # Behind the T-Net's zero-initialised output layer gradients start at zero.
        behind_zero_layer = name_.startswith(("input_transform.features",
                                              "input_transform.regression"))
        assert behind_zero_layer or parameter.grad.abs().sum() > 0, name_


def test_t_net_is_the_identity_at_initialisation() -> None:
    transform = InputTransform(3, [8, 16, 32, 16, 8])
    points = torch.randn(4, 50, 3)
    np.testing.assert_allclose(transform(points).detach().numpy(), np.tile(np.eye(3), (4, 1, 1)))
    extractor = PointNetExtractor(BOX, scale=0.1)
    # The transform leaves the points as they are: encoding them equals encoding without it.
    direct = extractor.encoder(points.transpose(1, 2)).max(dim=2).values
    torch.testing.assert_close(extractor.encode(points), direct)


def test_pcn_has_the_papers_layer_sizes() -> None:
    """Shared MLP 3->128->256, then 512->512->1024 (weights and biases of 1x1 convolutions)."""
    sizes = [(3, 128), (128, 256), (512, 512), (512, 1024)]
    expected = sum(width_in * width_out + width_out for width_in, width_out in sizes)
    extractor = PCNExtractor(gym.spaces.Box(-4, 4, (2048, 3), np.float32))
    assert sum(parameter.numel() for parameter in extractor.parameters()) == expected
    assert extractor.features_dim == 1024


def test_sphere_map_bins_the_directions() -> None:
    extractor = SphereMapExtractor(BOX, bins=(4, 8))
    # Straight up, straight down, and along +x / -y at the equator; one padding point at 0.
    points = torch.tensor([[[0.0, 0.0, 2.0], [0.0, 0.0, -1.0], [1.0, 0.01, 0.0],
                            [0.01, -1.0, 0.0], [0.0, 0.0, 0.0]]])
    maps = extractor.direction_map(points)[0]
    assert maps[0].sum() == pytest.approx(4 / 5)  # the padding point counts nowhere
    assert maps[0, 0].sum() == pytest.approx(1 / 5) and maps[0, 3].sum() == pytest.approx(1 / 5)
    assert maps[1, 0].max() == pytest.approx(2.0)  # mean distance of the top bin
    assert maps[0, 1:3].sum() == pytest.approx(2 / 5)
    assert maps[0, 1:3, 0].sum() == pytest.approx(1 / 5)  # +x: the first azimuth bin
    assert maps[0, 1:3, 6].sum() == pytest.approx(1 / 5)  # -y: three quarters round


SMOKE_RUNS = [("sac", "sphere", False), ("sac", "pcn", True), ("ppo", "pointnet", True)]
"""(algorithm, encoder, robot state) of the training smoke runs: SAC and PPO, Box and Dict."""


@pytest.mark.parametrize(("algorithm", "encoder", "robot_state"), SMOKE_RUNS)
def test_training_smoke_run(algorithm: str, encoder: str, robot_state: bool,
                            smoke_runs: SmokeRuns) -> None:
    config, result, run = smoke_runs(algorithm, encoder, robot_state)
    assert result["steps"] == 64 and 0.0 < result["coverage_pct"] <= 100.0
    for name in ("config.yaml", "command.txt", "memory.json", "monitor.csv",
                 "evaluations.csv", "best_model.zip", "final_model.zip", "curves.png",
                 "checkpoint.json"):
        assert (run / name).is_file(), name
    assert list((run / "logs" / "session_0").glob("events.out.tfevents.*"))
    assert (run / "logs" / "session_0" / "progress.csv").stat().st_size > 0
    memory = json.loads((run / "memory.json").read_text())
    assert memory == buffer_memory(config)
    checkpoint = _checkpoint(run)
    assert checkpoint["steps"] == result["steps"]
    assert (checkpoint["buffer"] is not None) == (algorithm == "sac")
    if algorithm == "sac":
        assert _buffer_size(run) == result["steps"]


def _buffer_size(run: Path) -> int:
    from stable_baselines3 import SAC

    model = SAC.load(run / "final_model.zip")
    load_buffer(model.replay_buffer, run / "checkpoints" / json.loads(
        (run / "checkpoint.json").read_text())["buffer"])
    return model.replay_buffer.size()


def _train_in_background(run: Path, options: list[str]) -> subprocess.Popen[bytes]:
    """`vprobot train` of the CPU profile with `options` into `run`, in a subprocess leading
    its own process group."""
    return subprocess.Popen([sys.executable, "-m", "vprobot.cli", "train",
                             str(PROFILES / "cpu.yaml"), *options, "--out", str(run)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)


def _wait_while_running(process: subprocess.Popen[bytes], ready: Callable[[], bool]) -> bool:
    """Wait (4 minutes at most) until `ready()`; whether `process` still runs then."""
    deadline = time.monotonic() + 240
    while process.poll() is None and time.monotonic() < deadline and not ready():
        time.sleep(0.05)
    return process.poll() is None and ready()


def _checkpoint(run: Path) -> dict[str, Any]:
    """The run's `checkpoint.json` (empty before its first checkpoint)."""
    path = run / "checkpoint.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def _logged_after_checkpoint(run: Path, steps: int) -> bool:
    """Whether the checkpoint at `steps` is the run's latest and an episode ended after it."""
    checkpoint = _checkpoint(run)
    return checkpoint.get("steps") == steps and count_lines(
        run / "monitor.csv") > checkpoint["log_lines"]["monitor.csv"]


def test_a_run_in_use_is_refused_and_a_killed_run_resumes_from_its_checkpoint(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """While a training runs (held still at its first checkpoint), a resume of its run is
    refused at once naming its pid and its curves can be drawn; let go, it trains on to its
    next checkpoint; killed (kill -9 of its process group) after logging more episodes, a
    resume goes on from that checkpoint, the logs cut back to it, to the end."""
    from vprobot.cli import main

    run = tmp_path / "run"
    # The free-flying sensor: what is tested is the run's lock and resume, and its steps are
    # the fastest.
    process = _train_in_background(run, ["--steps", "150", "--set", *TINY,
                                         "agent.checkpoint_freq=50", "env.carrier=free",
                                         "env.travel_cost=cartesian"])
    try:
        assert _wait_while_running(process, lambda: "steps" in _checkpoint(run)), (
            "the run ended early")
        # Stopped, the run cannot end before the resume is refused (but still holds its lock).
        os.killpg(process.pid, signal.SIGSTOP)
        assert (run / "run.lock").read_text().strip() == str(process.pid)
        assert main(["train", "--resume", "--out", str(run)]) == 2
        assert f"{run} is in use by pid {process.pid}" in capsys.readouterr().err
        # Reading a running run is fine.
        assert main(["curves", str(run), "--out", str(tmp_path / "during.png"),
                     "--window", "3"]) == 0
        assert process.poll() is None, "the run ended before the resume was refused"
        os.killpg(process.pid, signal.SIGCONT)
        if _wait_while_running(process, lambda: _logged_after_checkpoint(run, 100)):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == -signal.SIGKILL, "the run ended before it was killed"
    assert b"\0" not in (run / "monitor.csv").read_bytes()
    assert _checkpoint(run)["steps"] == 100
    assert main(["train", "--resume", "--out", str(run)]) == 0
    assert _checkpoint(run)["steps"] == 150
    assert _buffer_size(run) == 150
    # The monitor keeps the episodes up to the checkpoint, then the resumed ones, no others.
    monitor = (run / "monitor.csv").read_bytes()
    assert b"\0" not in monitor
    lines = monitor.decode().splitlines()
    assert lines[0].startswith("#") and lines[1].startswith("r,l,t,coverage")
    assert all(not line.startswith(("#", "r,")) for line in lines[2:])
    episodes = sum(int(line.split(",")[1]) for line in lines[2:])
    assert episodes <= 150 and abs(episodes - 150) <= 11
    assert len(read_monitor(run)["r"]) > 10
    assert main(["curves", str(run), "--out", str(tmp_path / "after.png"), "--window", "3"]) == 0


def test_agent_given_s_cov_sees_only_acquired_points(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every point the extractor is fed, in training and acting, is a point of an observation
    the env emitted, and every such point is one of the acquired cloud (as posed, scaled):
    nothing of the ground truth reaches the agent."""
    config = profile_config(PROFILES / "cpu.yaml", [*TINY, "agent.learning_starts=20"],
                            steps=60)
    fed: list[np.ndarray] = []
    original = SphereMapExtractor.encode

    def recording(self: SphereMapExtractor, points: torch.Tensor) -> torch.Tensor:
        fed.append(points.detach().numpy().reshape(-1, points.shape[-1]).copy())
        return original(self, points)

    monkeypatch.setattr(SphereMapExtractor, "encode", recording)
    env = make_vec_env(config, 0, [0], None)
    inspect = env.envs[0].unwrapped
    emitted: set[tuple[float, ...]] = set()
    gt_rows: set[tuple[float, ...]] = set()

    def acquired_rows() -> set[tuple[float, ...]]:
        episode = inspect.episode
        cloud = episode.tracker.accumulated_cloud @ episode.object_pose.rotation.T
        rows = np.clip(cloud / config.env.state_scale_m, -4, 4).astype(np.float32)
        gt = episode.tracker.gt_points @ episode.object_pose.rotation.T
        gt_rows.update(map(tuple, (gt / config.env.state_scale_m).astype(np.float32)))
        return set(map(tuple, rows)) | {(0.0, 0.0, 0.0)}

    def checked(observation: np.ndarray) -> np.ndarray:
        rows = set(map(tuple, observation))
        assert observation.shape[1] == 3 and rows <= acquired_rows()
        emitted.update(rows)
        return observation

    reset, step = inspect.reset, inspect.step
    monkeypatch.setattr(inspect, "reset", lambda **kwargs: (
        lambda result: (checked(result[0]), result[1]))(reset(**kwargs)))
    monkeypatch.setattr(inspect, "step", lambda action: (
        lambda result: (checked(result[0]), *result[1:]))(step(action)))
    model = build_model(config, env, seed=0, device="cpu")
    model.learn(60)
    model.predict(env.reset(), deterministic=True)
    assert len(fed) > 40
    for batch in fed:
        rows = set(map(tuple, batch))
        assert rows <= emitted
        assert not rows & gt_rows


@pytest.mark.parametrize(
    ("overrides", "message"),
    [(["agent.colour=red"], "unknown key 'colour' in section 'agent'"),
     (["agent.algorithm=a2c"], "agent.algorithm must be one of"),
     (["robot.arm=ur5"], "unknown config section 'robot'"),
     (["agent.encoder"], "section.key=value"),
     (["agent.buffer_size=2000000", "env.state_points=2048"], "GiB"),
     (["env.carrier=flying"], "env.carrier must be one of")],
)
def test_bad_profiles_are_clear_errors(overrides: list[str], message: str,
                                       tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=re.escape(message)):
        config = profile_config(PROFILES / "cpu.yaml", overrides)
        train(config, tmp_path / "run", progress=False)
    assert not (tmp_path / "run").exists()  # nothing half-created


def test_profiles_and_their_memory() -> None:
    paper = profile_config(PROFILES / "paper.yaml")
    assert (paper.agent.algorithm, paper.agent.encoder, paper.agent.net_arch,
            paper.agent.learning_rate, paper.agent.learning_rate_schedule, paper.agent.gamma,
            paper.agent.total_steps) == ("sac", "pcn", (128, 64), 7.8e-5, "linear", 0.9, 75_000)
    assert (paper.env.state, paper.env.action, paper.env.reward, paper.env.state_points) == (
        "s_cov", "A_3S2R_lim", "R2", 2048)
    memory = buffer_memory(paper)
    # Two 2048 x 3 float32 clouds, 5 action floats and 3 more per transition.
    assert memory["bytes_per_transition"] == 2 * 2048 * 3 * 4 + 5 * 4 + 12
    assert memory["total_bytes"] == memory["bytes_per_transition"] * 75_000 < 8 * 1024**3
    cpu = profile_config(PROFILES / "cpu.yaml")
    assert buffer_memory(cpu)["total_bytes"] < 1024**3
    assert replace(cpu, "env", carrier="free").env.carrier == "free"


def write_monitor(run: Path, columns: dict[str, list[float]]) -> Path:
    """A run folder whose monitor.csv (SB3's: a JSON header line, then the CSV) holds
    `columns`."""
    run.mkdir()
    rows = zip(*columns.values(), strict=True)
    (run / "monitor.csv").write_text(
        '#{"t_start": 0.0, "env_id": "InspectEnv"}\n' + ",".join(columns) + "\n"
        + "".join(",".join(map(str, row)) + "\n" for row in rows))
    return run


def test_curves_of_two_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each panel plots the mean of the two runs' trailing means over the shorter run, with a
    band from their minimum to their maximum: the values worked out by hand below."""
    longer = write_monitor(tmp_path / "a", {
        "r": [1, 3, 5, 7], "l": [2, 4, 6, 8], "t": [1, 2, 3, 4],
        "coverage": [0.5, 0.7, 0.9, 1.0], "acquisitions": [2, 4, 6, 8],
        "travel_sum_joint_time": [10, 20, 30, 40], "travel_sum_paper": [99, 99, 99, 99]})
    shorter = write_monitor(tmp_path / "b", {
        "r": [-1, 1, 3], "l": [4, 4, 4], "t": [1, 2, 3],
        "coverage": [0.3, 0.5, 0.7], "acquisitions": [4, 4, 4],
        "travel_sum_joint_time": [20, 20, 20], "travel_sum_paper": [99, 99, 99]})
    plotted: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def recording_save(figure: Any, path: Path, title: str) -> Path:
        for axis in figure.axes:
            band = axis.collections[0].get_paths()[0].vertices
            plotted[axis.get_title()] = (np.asarray(axis.lines[0].get_xydata()), band)
        return save_figure(figure, path, title)

    monkeypatch.setattr(curves_module, "save_figure", recording_save)
    out = plot_curves([longer, shorter], tmp_path / "curves.png", window=2)
    # Trailing means over 2 episodes of the first three: (mean, minimum, maximum) per panel.
    expected = {
        "coverage at episode end": ([40, 50, 70], [30, 40, 60], [50, 60, 80]),
        "acquisitions per episode": ([3, 3.5, 4.5], [2, 3, 4], [4, 4, 5]),
        "episode reward": ([0, 1, 3], [-1, 0, 2], [1, 2, 4]),
        "travel between views per episode": ([15, 17.5, 22.5], [10, 15, 20], [20, 20, 25]),
    }
    assert set(plotted) == set(expected)
    for title, (mean, low, high) in expected.items():
        line, band = plotted[title]
        np.testing.assert_allclose(line, np.column_stack([[1, 2, 3], mean]), err_msg=title)
        for episode in (1, 2, 3):
            heights = band[np.isclose(band[:, 0], episode), 1]
            np.testing.assert_allclose([heights.min(), heights.max()],
                                       [low[episode - 1], high[episode - 1]], err_msg=title)
    with Image.open(out) as image:
        assert image.format == "PNG" and image.size == (1210, 770)
    with pytest.raises(ValueError, match=r"no monitor\.csv"):
        plot_curves([tmp_path], tmp_path / "x.png")


def _filled_buffer(space: gym.Space, size: int, transitions: int) -> ReplayBuffer:
    """A replay buffer of `size` with `transitions` reproducible random transitions added."""
    kind = DictReplayBuffer if isinstance(space, gym.spaces.Dict) else ReplayBuffer
    buffer = kind(size, space, ACTION, device="cpu")
    space.seed(0)
    ACTION.seed(0)

    def observation() -> np.ndarray | dict[str, np.ndarray]:
        sample = space.sample()
        return ({key: value[None] for key, value in sample.items()}
                if isinstance(sample, dict) else sample[None])

    for index in range(transitions):
        buffer.add(observation(), observation(), ACTION.sample()[None],
                   np.array([float(index)]), np.array([index % 7 == 0]), [{}])
    return buffer


def _arrays(buffer: ReplayBuffer) -> dict[str, np.ndarray]:
    arrays = {}
    for name in ("observations", "next_observations", "actions", "rewards", "dones",
                 "timeouts"):
        value = getattr(buffer, name)
        arrays.update({f"{name}.{key}": item for key, item in value.items()}
                      if isinstance(value, dict) else {name: value})
    return arrays


@pytest.mark.parametrize("space", [BOX, DICT], ids=["box", "dict"])
@pytest.mark.parametrize("transitions", [30, 130], ids=["filling", "wrapped"])
def test_buffer_checkpoint_holds_the_filled_transitions_and_restores_them_exactly(
        space: gym.Space, transitions: int, tmp_path: Path) -> None:
    buffer = _filled_buffer(space, 100, transitions)
    save_buffer(buffer, tmp_path / "buffer.npz")
    restored = _filled_buffer(space, 100, 0)
    load_buffer(restored, tmp_path / "buffer.npz")
    assert (restored.pos, restored.full) == (buffer.pos, buffer.full) == (
        transitions % 100, transitions >= 100)
    original = _arrays(buffer)
    for name, array in _arrays(restored).items():
        np.testing.assert_array_equal(array, original[name], err_msg=name)
    # The file holds the filled transitions: a buffer 100 times larger writes as much.
    filled = min(transitions, 100)
    per_transition = sum(array[0].nbytes for array in original.values())
    size = (tmp_path / "buffer.npz").stat().st_size
    assert filled * per_transition < size < filled * per_transition + 8192
    save_buffer(_filled_buffer(space, 10_000, filled), tmp_path / "large.npz")
    assert (tmp_path / "large.npz").stat().st_size == size


def test_training_before_the_first_finished_episode_succeeds_without_curves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from vprobot.cli import main

    run = tmp_path / "run"
    assert main(["train", str(PROFILES / "cpu.yaml"), "--steps", "5", "--set", *TINY,
                 "--out", str(run)]) == 0
    out = capsys.readouterr().out
    assert "no finished episodes yet, so no curves.png" in out
    assert ("  best model (the one kept, agent.select), from step 5: coverage " in out
            and f"% at the goal: {run / 'best_model.zip'}\n" in out)
    assert (run / "final_model.zip").is_file() and not (run / "curves.png").exists()
    # Resumed once finished, it says so.
    assert main(["train", "--resume", "--out", str(run)]) == 0
    assert (f"{run} has finished: it trained its 5 steps (agent.total_steps) already; nothing "
            f"more to train\n") in capsys.readouterr().out


def test_train_reports_the_selected_best_model_and_where_it_is(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The model kept (best_model.zip, from an earlier evaluation) comes first, with its step
    and file; the final model, which may be worse, second."""
    import vprobot.training.train as training
    from vprobot.cli import main

    final = {"coverage_pct": 39.5, "acquisitions": 4.0, "success_pct": 20.0,
             "reachable_pct": 80.0, "steps": 75_000, "wall_s": 600.0, "curves": None}
    best = {"coverage_pct": 60.9, "acquisitions": 3.25, "success_pct": 50.0, "step": 40_000.0}
    monkeypatch.setattr(training, "train", lambda *args, **kwargs: {**final, "best": best})
    run = tmp_path / "run"
    assert main(["train", str(PROFILES / "cpu.yaml"), "--out", str(run)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[:3] == [
        "trained 75,000 steps in 10.0 min; on the validation episodes:",
        f"  best model (the one kept, agent.select), from step 40,000: coverage 60.9 %, 3.25 "
        f"acquisitions, 50 % at the goal: {run / 'best_model.zip'}",
        "  final model, step 75,000: coverage 39.5 %, 4.00 acquisitions, 20 % at the goal, 80 % "
        "of requests reachable"]


def _millimetre_motor(path: Path, factor: float) -> Path:
    mesh = trimesh.load(MOTORS_DIR / "test" / "motor_000.stl")
    mesh.apply_scale(factor)
    mesh.export(path)
    return path


@pytest.mark.parametrize(("options", "message"), [
    (["--set", "env.parts=mesh", "env.mesh=MM"],
     "largest side is 192.6 m with env.mesh_scale=1, outside the allowed 0.01 .. 5 m; looks like "
     "millimetres: use env.mesh_scale=0.001"),
    (["--set", "env.parts=mesh", "env.mesh=BIG"],
     "does not fit the cell: at env.mesh_scale=1 it measures"),
    (["--set", "env.parts=mesh", "env.mesh=MISSING"], "env.mesh not found"),
    (["--set", "agent.buffer_size=2000000", "env.state_points=2048"], "GiB"),
    (["--device", "cuda"], "--device cuda: no CUDA device on this machine"),
], ids=["millimetres", "too-large", "missing-mesh", "memory", "device"])
def test_failed_checks_leave_no_run_folder_behind(
        options: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.cli import main

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    meshes = {"MM": str(_millimetre_motor(tmp_path / "motor_mm.stl", 1000.0)),
              "BIG": str(_millimetre_motor(tmp_path / "motor_big.stl", 2.0)),
              "MISSING": str(tmp_path / "missing.stl")}
    options = [re.sub("MM|BIG|MISSING", lambda match: meshes[match.group()], option)
               for option in options]
    run = tmp_path / "run"
    assert main(["train", str(PROFILES / "cpu.yaml"), *options, "--out", str(run)]) == 2
    error = capsys.readouterr().err
    assert message in error and len(error.splitlines()) == 1
    assert not run.exists()
    assert main(["train", "--resume", "--out", str(run)]) == 2
    assert "is not a training run" in capsys.readouterr().err


def test_an_agent_with_other_observations_than_its_config_names_its_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from vprobot.agents.trained import load_agent

    config = profile_config(PROFILES / "cpu.yaml", TINY)
    run = tmp_path / "run"
    run.mkdir()
    build_model(config, make_vec_env(config, 0, [0], None), 0, "cpu").save(
        run / "best_model.zip")
    other = replace(config, "env", state_points=128)
    (run / "config.yaml").write_text(yaml.safe_dump(config_document(other)))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=re.escape(
            "agent run/best_model.zip: its run's config.yaml gives observations of shape "
            "(128, 3), but the model was trained on (64, 3)")):
        load_agent("run")


def test_the_monitor_file_of_each_env_rank_is_the_name_sb3_writes(tmp_path: Path) -> None:
    from stable_baselines3.common.monitor import Monitor

    for rank in range(3):
        Monitor(gym.make("CartPole-v1"), filename=str(tmp_path / monitor_file(rank))).close()
    assert sorted(path.name for path in tmp_path.iterdir()) == [
        "monitor.csv", "monitor_1.monitor.csv", "monitor_2.monitor.csv"]


class _ResumedModel:
    """What the callbacks read of a model resumed at step 200."""

    num_timesteps = 200

    def get_env(self) -> None:
        return None


def test_a_resumed_run_evaluates_and_checkpoints_on_the_frequency_grid(tmp_path: Path) -> None:
    """Evaluations every 100 steps, resumed from the checkpoint at step 200: the next ones are
    at 300 and 400 (SB3's order: set up, training start, then a call per step), not at 201 and
    301 (an off-grid evaluation would enter the best-model selection)."""
    model = _ResumedModel()
    evaluation = SharedEpisodeEvaluation(None, [], tmp_path, 100, 0.0, "coverage")
    checkpoint = ResumableCheckpoint(tmp_path, 100, [])
    evaluated: list[int] = []
    saved: list[int] = []
    evaluation.evaluate = lambda: evaluated.append(evaluation.num_timesteps) or {}
    checkpoint.save = lambda: saved.append(checkpoint.num_timesteps) or {}
    for callback in (evaluation, checkpoint):
        callback.init_callback(model)
        callback.on_training_start({}, {})
    for step in range(201, 401):
        model.num_timesteps = step
        for callback in (evaluation, checkpoint):
            callback.on_step()
            callback.on_rollout_end()
    assert evaluated == [300, 400] and saved == [300, 400]
