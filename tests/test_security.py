"""Loading an agent runs no code from its model file (docs/security.md): the pickled settings
of a stable-baselines3 zip are never unpickled, and the bundled agents load as
stable-baselines3's own (unpickling) loader loads them."""

from __future__ import annotations

import base64
import json
import shutil
import zipfile
from pathlib import Path

import cloudpickle
import numpy as np
import pytest
import torch

from vprobot.agents.trained import ALGORITHMS, BUNDLED_AGENTS, load_agent
from vprobot.cli import main

AGENT = "generalist-real"
"""The bundled agent the crafted files are made from (the quickest to load)."""


class _Payload:
    """What a hostile model file pickles: unpickling it creates the file `marker`."""

    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self) -> tuple[object, tuple[str, str]]:
        return open, (str(self.marker), "w")


def _crafted(folder: Path, key: str, marker: Path) -> Path:
    """A copy of the bundled agent's run in `folder`, its model's setting `key` (an existing or
    a new one) replaced by a pickled `_Payload`."""
    shutil.copytree(BUNDLED_AGENTS[AGENT], folder)
    model = folder / "model.zip"
    with zipfile.ZipFile(BUNDLED_AGENTS[AGENT] / "model.zip") as original:
        entries = {name: original.read(name) for name in original.namelist()}
    settings = json.loads(entries["data"])
    settings[key] = {":type:": "<class 'object'>", ":serialized:": base64.b64encode(
        cloudpickle.dumps(_Payload(marker))).decode()}
    entries["data"] = json.dumps(settings).encode()
    with zipfile.ZipFile(model, "w") as crafted:
        for name, data in entries.items():
            crafted.writestr(name, data)
    return folder


def test_a_pickled_setting_of_a_model_file_is_not_unpickled(tmp_path: Path) -> None:
    """Its run's config builds the value in its place: the agent loads and acts as before."""
    marker = tmp_path / "marker"
    crafted = load_agent(_crafted(tmp_path / "run", "lr_schedule", marker))
    assert not marker.exists()
    bundled = load_agent(AGENT)
    space = bundled.model.observation_space
    space.seed(0)
    for observation in (space.sample() for _ in range(10)):
        assert np.array_equal(crafted.model.predict(observation, deterministic=True)[0],
                              bundled.model.predict(observation, deterministic=True)[0])


def test_a_model_file_with_a_pickled_setting_no_model_has_is_refused_unpickled(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    marker = tmp_path / "marker"
    run = _crafted(tmp_path / "run", "payload", marker)
    assert main(["plan", "--planner", f"agent:{run}", "--out", str(tmp_path / "plan.json")]) == 2
    assert not marker.exists()
    assert capsys.readouterr().err.splitlines()[-1] == (
        f"vprobot plan: error: agent {run / 'model.zip'}: its model file holds pickled settings "
        f"a dqn model of its run does not have (payload); vprobot does not unpickle them, since "
        f"that runs code (docs/security.md)")


@pytest.mark.parametrize("agent", ["cpu", AGENT])
def test_a_bundled_agent_loads_as_stable_baselines_own_loader_loads_it(agent: str) -> None:
    """The same weights and the same actions as stable-baselines3's `load`, which unpickles
    (a SAC agent and a DQN one)."""
    loaded = load_agent(agent)
    reference = ALGORITHMS[loaded.config.agent.algorithm].load(loaded.path, device="cpu")
    weights, expected = loaded.model.policy.state_dict(), reference.policy.state_dict()
    assert weights.keys() == expected.keys()
    assert all(torch.equal(weights[name], expected[name]) for name in weights)
    space = reference.observation_space
    space.seed(0)
    for observation in (space.sample() for _ in range(10)):
        assert np.array_equal(loaded.model.predict(observation, deterministic=True)[0],
                              reference.predict(observation, deterministic=True)[0])
