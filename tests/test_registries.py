"""The extension points' registries: a planner and an encoder defined here, in the test file,
run through the same config and CLI paths as the bundled ones, with no edit elsewhere."""

from __future__ import annotations

import csv
import re
import sys
import types
from collections.abc import Iterator
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import torch
from stable_baselines3.common.vec_env import DummyVecEnv
from torch import nn

from vprobot.agents.encoders import ENCODERS, Encoder
from vprobot.agents.extractors import PointCloudExtractor
from vprobot.agents.training import build_model, profile_config
from vprobot.cli import main
from vprobot.config import ConfigError, load_config
from vprobot.episode import Episode, ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.paths import DEFAULT_MOTOR
from vprobot.planners.base import PLANNERS, PlanPlanner, register_planner
from vprobot.planners.runner import evaluated_planners, make_planner, planner_names
from vprobot.registry import Registry, UnknownNameError


class TopViews(PlanPlanner):
    """`toy<k>`: k views straight down onto the object from k heights."""

    name = "toy"
    pattern = r"(?P<count>[1-9])"
    usage = "toy<k>"
    stops_at_goal = False

    def __init__(self, count: int):
        super().__init__()
        self.count = count

    @classmethod
    def from_name(cls, config: object, views: int | None = None, **params: str) -> TopViews:
        return cls(int(params["count"]))

    def plan(self, episode: Episode) -> list[ViewRequest]:
        distance = episode.scene.cell.config.sensor.working_distance_m
        return [ViewRequest(SensorTarget.look_at(
            episode.center + [0.0, 0.0, distance * (1.0 - 0.02 * index)], episode.center))
            for index in range(self.count)]


class MaxPool(PointCloudExtractor):
    """A linear layer per point, max-pooled."""

    def __init__(self, observation_space: gym.Space, width: int):
        super().__init__(observation_space, width)
        self.layer = nn.Linear(self.columns, width)

    def encode(self, points: torch.Tensor) -> torch.Tensor:
        return self.layer(points).max(dim=1).values


class PointsEnv(gym.Env):
    """The spaces of an `s_cov` env, no simulation behind them."""

    observation_space = gym.spaces.Box(-4, 4, (32, 3), np.float32)
    action_space = gym.spaces.Box(-1, 1, (5,), np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        return np.zeros((32, 3), np.float32), {}

    def step(self, action: np.ndarray):
        return np.zeros((32, 3), np.float32), 0.0, True, False, {}


@pytest.fixture
def toy_planner() -> Iterator[type[TopViews]]:
    yield register_planner(TopViews)
    PLANNERS.unregister("toy")


@pytest.fixture
def toy_encoder() -> Iterator[None]:
    ENCODERS.register("toy", Encoder(MaxPool, settings=lambda agent: {"width":
                                                                        agent.net_arch[1]}))
    yield
    ENCODERS.unregister("toy")


def test_a_registry_lists_its_entries_in_name_order_and_names_what_it_allows() -> None:
    registry: Registry[int] = Registry("widget")
    registry.register("b", 2)

    @registry.register("a")
    def widget() -> int:
        return 1

    assert list(registry) == ["a", "b"] and registry["a"] is widget and "a" in registry
    with pytest.raises(ValueError, match="widget 'b' is already registered"):
        registry.register("b", 3)
    with pytest.raises(UnknownNameError) as error:
        registry["c"]
    assert isinstance(error.value, ValueError) and isinstance(error.value, KeyError)
    assert str(error.value) == "unknown widget 'c'; allowed: a, b"
    registry.register("a10", 10)
    registry.register("a9", 9)
    assert list(registry) == ["a", "a9", "a10", "b"]
    registry.unregister("a9"), registry.unregister("a10")
    assert registry.get("c") is None and 3 not in registry
    assert registry.unregister("b") == 2 and list(registry) == ["a"]


def test_a_registry_imports_the_modules_of_its_package_when_first_read(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    package = tmp_path / "toy_widgets"
    package.mkdir()
    (package / "__init__.py").write_text("")
    registration = ("from vprobot.registry import Registry\n"
                    "import sys\n"
                    "WIDGETS = sys.modules['toy_widgets_registry'].WIDGETS\n"
                    "WIDGETS.register({name!r}, {value})\n")
    (package / "zeta.py").write_text(registration.format(name="zeta", value=1))
    (package / "alpha.py").write_text(registration.format(name="alpha", value=2))
    (package / "_private.py").write_text("raise RuntimeError('a private module is no entry')")
    holder = types.ModuleType("toy_widgets_registry")
    holder.WIDGETS = Registry("widget", package="toy_widgets")  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "toy_widgets_registry", holder)
    monkeypatch.syspath_prepend(str(tmp_path))
    widgets = holder.WIDGETS
    # Registering does not import the package; the first read does, once.
    widgets.register("mine", 3)
    assert "toy_widgets.zeta" not in sys.modules
    assert list(widgets) == ["alpha", "mine", "zeta"] and widgets["zeta"] == 1
    assert "toy_widgets.alpha" in sys.modules and "toy_widgets._private" not in sys.modules
    for module in ("toy_widgets", "toy_widgets.alpha", "toy_widgets.zeta"):
        monkeypatch.delitem(sys.modules, module)


def test_a_bundled_module_that_fails_to_import_fails_every_read_of_its_registry(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    package = tmp_path / "broken_widgets"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "bad.py").write_text("raise ImportError('bad widget')")
    widgets: Registry[int] = Registry("widget", package="broken_widgets")
    monkeypatch.syspath_prepend(str(tmp_path))
    for _ in range(2):
        with pytest.raises(ImportError, match="bad widget"):
            list(widgets)
    monkeypatch.delitem(sys.modules, "broken_widgets")


def test_a_planner_registered_elsewhere_is_built_by_name_and_evaluated(
        toy_planner: type[TopViews], tmp_path: Path) -> None:
    assert "toy<k>" in planner_names()
    planner = make_planner("toy3", load_config())
    assert isinstance(planner, TopViews) and planner.count == 3
    with pytest.raises(ValueError, match=r"unknown planner 'toy'; allowed: .*toy<k>"):
        make_planner("toy", load_config())
    assert main(["evaluate", "--planners", "toy2", "--motors", str(DEFAULT_MOTOR), "--seeds", "0",
                 "--carriers", "free", "--out", str(tmp_path)]) == 0
    with (tmp_path / "evaluation_episodes.csv").open() as stream:
        (row,) = csv.DictReader(stream)
    # The free-flying sensor acquires every request: both views.
    assert (row["planner"], row["requested"], row["acquisitions"]) == ("toy2", "2", "2")
    assert 0.0 < float(row["coverage_pct"]) < 100.0


def test_planners_are_listed_in_name_order_whichever_registered_first() -> None:
    # The planners' modules register when first imported, which one first depends on the
    # caller (the stop rules import nbv); register nbv again last.
    PLANNERS.register("nbv", PLANNERS.unregister("nbv"))
    names = planner_names()
    assert names.index("nbv") < names.index("uniform<k>")
    assert names == [PLANNERS[name].usage or name for name in sorted(PLANNERS)]


def test_evaluates_default_planners_are_what_each_planner_declares_in_name_order() -> None:
    # From the planner classes themselves: B_SCP with 4 and 5 views, nbv stopping at the grid,
    # not the exact optimum (minutes per episode), which is a B_SCP subclass.
    defaults = evaluated_planners()
    assert {"bscp", "bscp4", "bscp5", "nbv@grid", "uniform5", "random2"} <= set(defaults)
    assert "optimum" not in defaults and len(set(defaults)) == len(defaults)
    owners = [next(name for name in sorted(PLANNERS, key=len, reverse=True)
                   if default.startswith(name)) for default in defaults]
    assert owners == sorted(owners)


def test_after_unregistering_the_planner_is_unknown(tmp_path: Path) -> None:
    assert "toy" not in PLANNERS
    with pytest.raises(ValueError, match="unknown planner 'toy2'"):
        make_planner("toy2", load_config())


def test_a_config_naming_a_registered_encoder_builds_a_model_with_it(
        toy_encoder: None, tmp_path: Path) -> None:
    path = tmp_path / "toy.yaml"
    path.write_text("agent: {encoder: toy, net_arch: [8, 6], batch_size: 4, buffer_size: 16,\n"
                    "        learning_starts: 4}\n")
    config = load_config(path)
    model = build_model(config, DummyVecEnv([PointsEnv]), seed=0, device="cpu")
    extractor = model.policy.actor.features_extractor
    assert isinstance(extractor, MaxPool) and extractor.features_dim == 6
    action, _ = model.predict(np.zeros((1, 32, 3), np.float32), deterministic=True)
    assert action.shape == (1, 5)


def test_an_unregistered_encoder_is_refused_with_the_registered_names_where_the_agent_is_used(
        tmp_path: Path) -> None:
    path = tmp_path / "toy.yaml"
    path.write_text("agent: {encoder: toy}\n")
    # The config loads: it does not read the encoders, whose modules import torch.
    assert load_config(path).agent.encoder == "toy"
    with pytest.raises(ConfigError, match=re.escape(f"agent.encoder must be one of "
                                                    f"{list(ENCODERS)}, got 'toy'")):
        profile_config(path)
