"""A reward and an encoder of a user's own, in `.py` plugins outside the package: each is one
file that registers itself, and runs through the config and the command line (a training run,
then its evaluation on two Ray workers), as docs/extending.md says. (The sensing model's toy is
in tests/test_extensions.py, whose Ray evaluation runs it.)"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml
from helpers import TINY_TRAINING

from vprobot.agents.encoders import ENCODERS
from vprobot.cli import main
from vprobot.config import ConfigError, load_config
from vprobot.extensions import plugins
from vprobot.files.paths import CONFIGS_DIR, DEFAULT_MOTOR
from vprobot.rewards import REWARDS

ROOT = Path(__file__).resolve().parents[1]
LIGHT = '''"""A user's own reward (no torch)."""

from vprobot.rewards import REWARDS, RewardFormula

REWARDS.register("twice_gain", RewardFormula(True, lambda delta, remaining, travel: 2.0 * delta))
'''
ENCODER = '''"""A user's own encoder: a linear layer per point, max-pooled, with its setting."""

import dataclasses

from torch import nn

from vprobot.agents.encoders import ENCODERS, Encoder
from vprobot.agents.extractors import PointCloudExtractor


class MaxPool(PointCloudExtractor):
    def __init__(self, observation_space, width):
        super().__init__(observation_space, width)
        self.layer = nn.Linear(self.columns, width)

    def encode(self, points):
        return self.layer(points).max(dim=1).values


@dataclasses.dataclass(frozen=True)
class Width:
    width: int = 24


ENCODERS.register("maxpool_toy", Encoder(MaxPool, settings=Width))
'''
PROFILE = CONFIGS_DIR / "agents" / "cpu.yaml"
ONE_FREE_EPISODE = ["--parts", str(DEFAULT_MOTOR), "--carriers", "free"]


@pytest.fixture
def toys(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Path, Path]]:
    """The two plugin files (not yet loaded); afterwards this process without them, their
    modules and what they registered."""
    monkeypatch.setattr(plugins, "_loaded", [])
    light, encoder = tmp_path / "light_toys.py", tmp_path / "encoder_toy.py"
    light.write_text(LIGHT)
    encoder.write_text(ENCODER)
    registries = (REWARDS, ENCODERS)
    before = [set(registry) for registry in registries]
    yield light, encoder
    for registry, names in zip(registries, before, strict=True):
        for name in set(registry) - names:
            registry.unregister(name)
    for module in ("light_toys", "encoder_toy"):
        sys.modules.pop(module, None)


def test_a_plugin_reward_is_named_by_the_config_and_paid_by_the_env(
        toys: tuple[Path, Path], tmp_path: Path) -> None:
    from vprobot.env.inspect_env import InspectEnv

    config = tmp_path / "twice.yaml"
    config.write_text("env: {reward: twice_gain}\n")
    with pytest.raises(ConfigError, match=r"env.reward must be one of"):
        load_config(config)
    plugins.load([str(toys[0])])
    assert load_config(config).env.reward == "twice_gain"
    with pytest.raises(ConfigError, match=r"env.reward must be one of \[.*'twice_gain'.*\], "
                                          r"got 'R99'"):
        config.write_text("env: {reward: R99}\n")
        load_config(config)
    # The free-flying sensor acquires every request; A_2S0R looks at the centre from
    # (azimuth, polar angle) at the working distance.
    env = InspectEnv(parts="mesh", mesh=str(DEFAULT_MOTOR), resolution=(107, 75),
                     reward="twice_gain", carrier="free", travel_cost="cartesian",
                     action="A_2S0R")
    env.reset(seed=0)
    gains = []
    for phi, theta in ((0.0, 1.2), (2.1, 1.2), (4.2, 1.2)):
        action = np.array([phi / np.pi - 1.0, 2.0 * theta / np.pi - 1.0], dtype=np.float32)
        _, reward, *_, info = env.step(action)
        gains.append(info["delta_coverage"])
        assert reward == 2.0 * info["delta_coverage"]
    assert max(gains) > 0.0


def test_a_plugin_reward_and_encoder_train_an_agent_that_two_ray_workers_evaluate(
        toys: tuple[Path, Path], tmp_path: Path) -> None:
    """Trained from the command line with both toys; then `vprobot evaluate --workers 2` of
    that run, in a fresh process: each Ray task loads the run, whose config names the toy reward
    and whose model holds the toy encoder, so the workers must have imported both plugins."""
    pytest.importorskip("ray")
    from vprobot.agents.trained import load_agent

    run = tmp_path / "run"
    given = ["--plugin", str(toys[0]), "--plugin", str(toys[1])]
    assert main([*given, "train", str(PROFILE), "--steps", "5", "--set", *TINY_TRAINING,
                 "env.reward=twice_gain", "agent.encoder=maxpool_toy",
                 "agent.encoder_settings.maxpool_toy.width=12", "--out", str(run)]) == 0
    saved = yaml.safe_load((run / "config.yaml").read_text())
    assert (saved["env"]["reward"], saved["agent"]["encoder"]) == ("twice_gain", "maxpool_toy")
    assert saved["agent"]["encoder_settings"]["maxpool_toy"] == {"width": 12}
    # The setting the plugin file declares (its default 24) sizes the network the run loads.
    extractor = load_agent(run).model.policy.actor.features_extractor
    assert type(extractor).__name__ == "MaxPool" and extractor.features_dim == 12

    out = tmp_path / "evaluation"
    evaluated = subprocess.run(
        [sys.executable, "-m", "vprobot.cli", *given, "evaluate", "--planners", f"agent:{run}",
         *ONE_FREE_EPISODE, "--seeds", "0", "1", "--workers", "2", "--out", str(out)],
        capture_output=True, text=True, timeout=600)
    assert evaluated.returncode == 0, evaluated.stderr
    with (out / "evaluation_episodes.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert sorted((row["episode"], row["planner"]) for row in rows) == [
        ("0", f"agent:{run}"), ("1", f"agent:{run}")]
    assert all(int(row["acquisitions"]) >= 1 for row in rows)


def test_a_plugin_reward_reaches_the_envs_of_subprocesses(
        toys: tuple[Path, Path], tmp_path: Path) -> None:
    """At `agent.n_envs: 2` each env is made in a `SubprocVecEnv` child (forkserver), a fresh
    process that looks the reward up by name: it must have loaded the plugin first."""
    run = tmp_path / "run"
    assert main(["--plugin", str(toys[0]), "train", str(PROFILE), "--steps", "8", "--set",
                 *TINY_TRAINING, "env.reward=twice_gain", "agent.n_envs=2",
                 "--out", str(run)]) == 0
    # Each child wrote its monitor's header once it had made its env.
    assert (run / "monitor.csv").is_file() and (run / "monitor_1.monitor.csv").is_file()


def test_an_unknown_encoder_is_refused_where_the_agent_is_used_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["train", str(PROFILE), "--set", "agent.encoder=nope", "--out", str(out)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("vprobot train: error: agent.encoder must be one of [")
    assert "'pcn'" in line and line.endswith("], got 'nope'") and not out.exists()
    # A run folder whose config names it is refused before its model is read.
    run = tmp_path / "copied"
    run.mkdir()
    document = yaml.safe_load((CONFIGS_DIR / "default.yaml").read_text()) or {}
    (run / "config.yaml").write_text(yaml.safe_dump({**document, "agent": {"encoder": "nope"}}))
    (run / "best_model.zip").write_text("not read")
    assert main(["evaluate", "--planners", f"agent:{run}", *ONE_FREE_EPISODE, "--seeds", "0",
                 "--out", str(tmp_path / "evaluation")]) == 2
    # After the progress line that says which agent it loads.
    error = capsys.readouterr().err.splitlines()[-1]
    assert error.startswith(f"vprobot evaluate: error: {run / 'config.yaml'}: agent.encoder "
                            f"must be one of [")


def test_loading_a_config_that_names_an_unknown_encoder_imports_no_torch(tmp_path: Path) -> None:
    """The encoders' modules import torch (2 s): the config leaves `agent.encoder` to the agents."""
    path = tmp_path / "nope.yaml"
    path.write_text("agent: {encoder: nope}\n")
    code = (f"import sys\nfrom vprobot.config import load_config\n"
            f"assert load_config({str(path)!r}).agent.encoder == 'nope'\n"
            f"print('torch' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert result.stdout.strip() == "False"
