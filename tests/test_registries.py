"""The extension points' registries: a planner and an encoder defined here, in the test file,
run through the same config and CLI paths as the bundled ones, with no edit elsewhere."""

from __future__ import annotations

import csv
import dataclasses
import json
import re
import subprocess
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

from vprobot.agents.encoders import ENCODERS, Encoder, network_arguments
from vprobot.agents.extractors import PointCloudExtractor
from vprobot.cli import main
from vprobot.config import ConfigError, load_config
from vprobot.episode import Episode, ViewRequest
from vprobot.extensions.registry import Bundled, Registry, UnknownNameError
from vprobot.files.paths import DEFAULT_MOTOR
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import (
    PLANNERS,
    Planner,
    PlanPlanner,
    evaluated_planners,
    planner_names,
    register_planner,
)
from vprobot.planners.runner import make_planner
from vprobot.planners.self_stopping import SelfStopping
from vprobot.training.train import build_model, profile_config


class TopViews(SelfStopping, PlanPlanner):
    """`toy<k>`: k views straight down onto the object from k heights, run to their end."""

    name = "toy"
    pattern = r"(?P<count>[1-9])"
    usage = "toy<k>"

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


@dataclasses.dataclass(frozen=True)
class Width:
    """The toy encoder's one setting, beside it."""

    width: int = 6

    def __post_init__(self) -> None:
        if self.width < 1:
            raise ConfigError(f"width must be >= 1, got {self.width}")


@pytest.fixture
def toy_encoder() -> Iterator[None]:
    ENCODERS.register("toy", Encoder(MaxPool, settings=Width))
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


def _widgets(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, modules: dict[str, str],
             bundled: dict[str, Bundled]) -> Registry[int]:
    """A registry of widgets declared in a package `toy_widgets` of `modules` (name -> code,
    where `WIDGETS` is the registry), the modules forgotten afterwards."""
    package = tmp_path / "toy_widgets"
    package.mkdir()
    (package / "__init__.py").write_text(
        "import sys\nWIDGETS = sys.modules['toy_widgets_registry'].WIDGETS\n")
    for module, code in modules.items():
        (package / f"{module}.py").write_text(f"from toy_widgets import WIDGETS\n{code}")
    holder = types.ModuleType("toy_widgets_registry")
    widgets: Registry[int] = Registry("widget", bundled=bundled, facts={"size": 0})
    holder.WIDGETS = widgets  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "toy_widgets_registry", holder)
    monkeypatch.syspath_prepend(str(tmp_path))
    for module in ("toy_widgets", *(f"toy_widgets.{name}" for name in modules)):
        monkeypatch.delitem(sys.modules, module, raising=False)
    return widgets


def test_a_registry_lists_its_declared_entries_and_imports_one_on_its_first_lookup(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    widgets = _widgets(tmp_path, monkeypatch, {
        "zeta": "ZETA = WIDGETS.register('zeta', 1)\n",
        "alpha": "ALPHA = WIDGETS.register('alpha', 2)\n",
    }, {"zeta": Bundled("toy_widgets.zeta:ZETA", size=5),
        "alpha": Bundled("toy_widgets.alpha:ALPHA")})
    widgets.register("mine", 3)
    # Names, `in`, facts and the message of an unknown name import no declared module.
    assert list(widgets) == ["alpha", "mine", "zeta"] and "zeta" in widgets and len(widgets) == 3
    assert widgets.fact("zeta", "size") == 5 and widgets.fact("alpha", "size") == 0
    with pytest.raises(UnknownNameError, match="allowed: alpha, mine, zeta"):
        widgets["omega"]
    assert "toy_widgets.zeta" not in sys.modules and "toy_widgets.alpha" not in sys.modules
    assert widgets["zeta"] == 1
    assert "toy_widgets.zeta" in sys.modules and "toy_widgets.alpha" not in sys.modules


def test_a_name_taken_from_a_bundled_entry_is_refused_at_once(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    widgets = _widgets(tmp_path, monkeypatch, {"zeta": "ZETA = WIDGETS.register('zeta', 1)\n"},
                       {"zeta": Bundled("toy_widgets.zeta:ZETA")})
    with pytest.raises(ValueError, match="widget 'zeta' is already registered; give it another"):
        widgets.register("zeta", 7)
    assert widgets["zeta"] == 1
    with pytest.raises(ValueError, match="widget 'zeta' is already registered"):
        widgets.register("zeta", 7)


def test_a_declaration_its_module_does_not_register_fails_its_lookup(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    widgets = _widgets(tmp_path, monkeypatch, {"zeta": "ZETA = 1\n"},
                       {"zeta": Bundled("toy_widgets.zeta:ZETA")})
    with pytest.raises(ImportError, match=re.escape(
            "widget 'zeta' is declared as toy_widgets.zeta:ZETA, which does not register it")):
        widgets["zeta"]
    with pytest.raises(ValueError, match=re.escape(
            "an entry string is 'package.module:attribute', got 'toy_widgets.zeta'")):
        Bundled("toy_widgets.zeta")


def test_a_bundled_module_that_fails_to_import_fails_every_lookup_of_its_entry(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    widgets = _widgets(tmp_path, monkeypatch, {"bad": "raise ImportError('bad widget')\n"},
                       {"bad": Bundled("toy_widgets.bad:BAD")})
    assert list(widgets) == ["bad"]
    for _ in range(2):
        with pytest.raises(ImportError, match="bad widget"):
            widgets["bad"]


def test_an_abstract_class_is_refused_at_its_registration_naming_what_it_lacks() -> None:
    class Half(Planner):
        name = "half"

        def reset(self, episode: Episode, rng: np.random.Generator) -> None:
            pass

    class Empty(Planner):
        name = "empty"

    with pytest.raises(TypeError, match=r"planner 'half' is abstract: it does not define "
                                        r"next_view$"):
        register_planner(Half)
    with pytest.raises(TypeError, match=r"planner 'empty' is abstract: it does not define "
                                        r"reset, next_view$"):
        register_planner(Empty)
    assert "half" not in PLANNERS and "empty" not in PLANNERS


REGISTRIES = {
    "PLANNERS": ("vprobot.planners.base", "vprobot.planners"),
    "STOPS": ("vprobot.stopping.rules.base", "vprobot.stopping.rules"),
    "REWARDS": ("vprobot.rewards.base", "vprobot.rewards"),
    "SENSING_MODELS": ("vprobot.sensing.models", "vprobot.sensing"),
    "ENCODERS": ("vprobot.agents.encoders", "vprobot.agents.extractors"),
    "FAMILIES": ("vprobot.families.base", "vprobot.families"),
    "FORMATS": ("vprobot.export.formats.base", "vprobot.export.formats"),
}
"""Each registry (module, name) and the package of its bundled entries."""

_DRIFT = """
import importlib, json, pkgutil, sys, types
registries = json.loads(sys.argv[1])
found = {}
for name, (module, package) in registries.items():
    registry = getattr(importlib.import_module(module), name)
    for info in pkgutil.iter_modules(importlib.import_module(package).__path__):
        importlib.import_module(f"{package}.{info.name}")
    entries = dict(registry._entries)
    declared = {}
    for entry, bundled in registry.bundled.items():
        target = getattr(importlib.import_module(bundled.module), bundled.attribute)
        value = entries.get(entry)
        # What an entry string names: the entry, the class of it (a part family) or the
        # function it wraps (an export format's writer).
        declared[entry] = {
            "target": value is target or type(value) is target
                      or getattr(value, "write", None) is target,
            # A class or function there, not one imported into the module.
            "defined_there": not isinstance(target, (type, types.FunctionType))
                             or target.__module__ == bundled.module,
            "facts": all(getattr(value, key) == bundled.facts.get(key, default)
                         for key, default in registry.facts.items())}
    found[name] = {"registered": sorted(entries), "declared": declared}
print(json.dumps(found))
"""


def test_each_registrys_declared_bundled_entries_are_what_its_package_registers() -> None:
    """The lazy index cannot drift from the code: in a fresh process, every module of each
    registry's package imported registers exactly the declared names, each where its entry
    string says, with the declared facts."""
    child = subprocess.run([sys.executable, "-c", _DRIFT, json.dumps(REGISTRIES)],
                           capture_output=True, text=True, check=True)
    found = json.loads(child.stdout.splitlines()[-1])
    for name, report in found.items():
        assert report["registered"] == sorted(report["declared"]), name
        for entry, checks in report["declared"].items():
            assert checks == {"target": True, "defined_there": True, "facts": True}, (name, entry)


def test_a_planner_registered_elsewhere_is_built_by_name_and_evaluated(
        toy_planner: type[TopViews], tmp_path: Path) -> None:
    assert "toy<k>" in planner_names()
    planner = make_planner("toy3", load_config())
    assert isinstance(planner, TopViews) and planner.count == 3
    with pytest.raises(ValueError, match=r"unknown planner 'toy'; allowed: .*toy<k>"):
        make_planner("toy", load_config())
    assert main(["evaluate", "--planners", "toy2", "--parts", str(DEFAULT_MOTOR), "--seeds", "0",
                 "--carriers", "free", "--out", str(tmp_path)]) == 0
    with (tmp_path / "evaluation_episodes.csv").open() as stream:
        (row,) = csv.DictReader(stream)
    # The free-flying sensor acquires every request: both views.
    assert (row["planner"], row["requested"], row["acquisitions"]) == ("toy2", "2", "2")
    assert 0.0 < float(row["coverage_pct"]) < 100.0


def test_planners_are_listed_in_name_order_whichever_registered_first(
        toy_planner: type[TopViews]) -> None:
    # The toy registered after every bundled planner was declared.
    names = planner_names()
    assert names.index("nbv") < names.index("toy<k>") < names.index("uniform<k>")
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


@pytest.mark.parametrize("settings", ["", ", encoder_settings: {toy: {width: 9}}"])
def test_a_config_naming_a_registered_encoder_builds_a_model_with_it_and_its_settings(
        toy_encoder: None, tmp_path: Path, settings: str) -> None:
    """The encoder's setting is declared with it, not in the config: its default, or the value
    under its name in `agent.encoder_settings`, sizes the network."""
    path = tmp_path / "toy.yaml"
    path.write_text(f"agent: {{encoder: toy, net_arch: [8, 6], batch_size: 4, buffer_size: 16,\n"
                    f"        learning_starts: 4{settings}}}\n")
    config = load_config(path)
    model = build_model(config, DummyVecEnv([PointsEnv]), seed=0, device="cpu")
    extractor = model.policy.actor.features_extractor
    assert isinstance(extractor, MaxPool) and extractor.features_dim == (9 if settings else 6)
    action, _ = model.predict(np.zeros((1, 32, 3), np.float32), deterministic=True)
    assert action.shape == (1, 5)


@pytest.mark.parametrize(("settings", "message"), [
    ("{toy: {depth: 2}}", "unknown key 'depth' in section 'agent.encoder_settings.toy'; allowed "
                          "keys: width"),
    ("{toy: {width: 0}}", "agent.encoder_settings.toy: width must be >= 1, got 0"),
    ("{toy: 3}", "agent.encoder_settings.toy must be a mapping of settings, got 3"),
    ("{toys: {}}", "a key of agent.encoder_settings must be one of"),
])
def test_bad_encoder_settings_are_refused_naming_the_key_where_the_agent_is_used(
        toy_encoder: None, tmp_path: Path, settings: str, message: str) -> None:
    path = tmp_path / "toy.yaml"
    path.write_text(f"agent: {{encoder: toy, encoder_settings: {settings}}}\n")
    with pytest.raises(ConfigError, match=re.escape(message)):
        profile_config(path)


def test_the_former_keys_of_the_encoders_settings_are_read_under_each_encoder_with_a_warning(
        tmp_path: Path) -> None:
    """A config written before the encoders owned their settings: the keys move under the
    encoders that read them, and each network gets the value written."""
    path = tmp_path / "old.yaml"
    path.write_text("agent: {encoder: sphere, encoder_scale: 0.5, sphere_bins: [4, 8], "
                    "sphere_features: 32}\n")
    with pytest.warns(FutureWarning, match="agent.encoder_scale, agent.sphere_bins, "
                                           "agent.sphere_features: an encoder's settings"):
        agent = load_config(path).agent
    assert agent.encoder_settings == {"pcn": {"scale": 0.5}, "pointnet": {"scale": 0.5},
                                      "sphere": {"bins": [4, 8], "features": 32}}
    assert network_arguments(agent) == {"bins": (4, 8), "features": 32}
    assert network_arguments(dataclasses.replace(agent, encoder="pcn")) == {"scale": 0.5}
    # An old override on the command line too.
    with pytest.warns(FutureWarning):
        config = profile_config(path, ["agent.encoder_scale=0.25"])
    assert config.agent.encoder_settings["pointnet"] == {"scale": 0.25}


def test_an_unregistered_encoder_is_refused_with_the_registered_names_where_the_agent_is_used(
        tmp_path: Path) -> None:
    path = tmp_path / "toy.yaml"
    path.write_text("agent: {encoder: toy}\n")
    # The config loads: it does not read the encoders, whose modules import torch.
    assert load_config(path).agent.encoder == "toy"
    with pytest.raises(ConfigError, match=re.escape(f"agent.encoder must be one of "
                                                    f"{list(ENCODERS)}, got 'toy'")):
        profile_config(path)
