"""Loading a trained agent: the bundled one, a run directory or a checkpoint file.

A stable-baselines3 model file is a zip whose `data` entry holds the model's settings as JSON,
some of them (the policy class, the spaces, the schedules) as cloudpickled objects, which run
code when unpickled: a model file from someone else could run anything. So `load_agent` never
unpickles them: it builds the model the run's `config.yaml` builds (`build_model`) and hands
stable-baselines3 that model's values in their place (its `custom_objects`, which it takes
instead of unpickling); the weights are read with torch's `weights_only` loader
(docs/security.md).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import re
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import gymnasium as gym
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm

from vprobot.agents.candidate_q import CandidateDQN
from vprobot.agents.encoders import check_encoder
from vprobot.agents.models import build_model
from vprobot.config import Config, ConfigError, SensorConfig, from_mapping, read_yaml
from vprobot.config.sensor import SensorModel
from vprobot.env.actions import ActionMapping
from vprobot.env.observations import observation_space
from vprobot.files.paths import AGENTS_DIR, names_a_path

BUNDLED_AGENTS = {path.name: path for path in sorted(AGENTS_DIR.iterdir()) if path.is_dir()}
"""The agents vprobot ships, by name (`--planner agent:NAME`), one run folder each with a README
saying how it was trained: `generalist-real` (the candidate-view agent of the realistic cell,
`configs/agents/real-candidates.yaml`), `generalist` (that of the paper's cell,
`configs/agents/cpu-candidates.yaml`), `cpu` (the motors-only agent of `configs/agents/cpu.yaml`,
the paper's setting) and `cpu-stop` (which decides itself when to stop)."""
DEFAULT_AGENTS = ("generalist-real", "generalist")
"""The agents of `--planner agent`: the first trained with the run's sensor and sensing model."""
BUNDLED_AGENT = AGENTS_DIR / DEFAULT_AGENTS[-1]
"""The agent `load_agent` gives without a source: the default of the paper's sensor."""
RUN_MODELS = ("best_model.zip", "final_model.zip", "model.zip")
"""What a directory offers, in order of preference."""
ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"sac": SAC, "ppo": PPO, "dqn": CandidateDQN}
"""The stable-baselines3 class of each `agent.algorithm`: built, resumed and loaded as this."""


@dataclasses.dataclass(frozen=True)
class TrainedAgent:
    """A policy and the configuration it was trained with (state, action mapping).

    Attributes:
        model: The stable-baselines3 model (on the CPU).
        config: The run's resolved configuration.
        path: The model file.
    """

    model: BaseAlgorithm
    config: Config
    path: Path


def model_file(name: str) -> Path:
    """The model file of a bundled agent's name, a run directory or a model file; an explicit
    path (`./cpu`) is never a bundled agent's name."""
    source = (BUNDLED_AGENTS[name] if name in BUNDLED_AGENTS and not names_a_path(name)
              else Path(name).expanduser())
    if source.is_dir():
        for model in RUN_MODELS:
            if (source / model).is_file():
                return source / model
        raise ValueError(f"agent {source}: no {', '.join(RUN_MODELS)} in the folder; is it a "
                         f"training run?")
    if source.is_file():
        return source
    raise ValueError(f"agent {source} does not exist (give a bundled agent: "
                     f"{', '.join(BUNDLED_AGENTS)}, a run directory or a model .zip)")


def load_run_config(run_dir: Path) -> Config:
    """The resolved config a run was started with, its encoder checked (`check_encoder`).

    Raises:
        ValueError: If the run directory has none, or it is empty or not a config, or names an
            encoder not registered here (naming it).
    """
    path = run_dir / "config.yaml"
    if not path.is_file():
        raise ValueError(f"{run_dir} is not a training run (no config.yaml)")
    data = read_yaml(path)
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: a run's config must be a mapping of config sections, as "
                          f"`vprobot train` writes it; got {type(data).__name__}"
                          f"{' (an empty file)' if data is None else ''}")
    try:
        config = from_mapping(Config, data)
        check_encoder(config.agent)
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from None
    return config


def _run_config(model_file: Path, shown: Path) -> Config:
    """The config of the run a model file (absolute; `shown` as the user named it) belongs to:
    beside it, or in a folder above it."""
    for folder in (model_file.parent, *model_file.parents[:3]):
        if (folder / "config.yaml").is_file():
            return load_run_config(folder)
    raise ValueError(f"agent {shown}: no config.yaml of its run beside it or above it")


def load_agent(source: str | Path | None = None) -> TrainedAgent:
    """Load an agent for planning on the CPU; no network access, no GPU needed.

    Args:
        source: A bundled agent's name (`BUNDLED_AGENTS`), a run directory (its best model), a
            model .zip inside a run, or None for the default bundled agent.

    Raises:
        ValueError: For a missing path, a folder without a model, a model whose run config is
            missing, a file that is not a loadable model, or a model whose observations are not
            those of its run's config.
    """
    shown = model_file(str(source if source is not None else BUNDLED_AGENT))
    resolved = shown.resolve()
    return _load(resolved, resolved.stat().st_mtime_ns, shown)


def trained_with(trained: SensorConfig, given: SensorConfig) -> bool:
    """Whether an agent trained with the sensor `trained` plans with `given`: the same rays,
    opening angles and range (its observations are built from that sensor's frames) and the
    same sensing model (what a view measures decides what it learned to request)."""
    return (SensorModel.from_config(trained) == SensorModel.from_config(given)
            and trained.sensing_model == given.sensing_model)


def describe_sensor(sensor: SensorConfig) -> str:
    """A sensor as the messages about an agent's sensor name it."""
    width, height = sensor.resolution
    return (f"{width} x {height} rays, {sensor.fov_deg[0]:g} x {sensor.fov_deg[1]:g} deg, "
            f"{sensor.near_m:g}-{sensor.far_m:g} m, {sensor.sensing} sensing")


@functools.cache
def _bundled_sensor(name: str) -> SensorConfig:
    # Read once: an evaluation builds its agent planner every episode.
    return load_run_config(BUNDLED_AGENTS[name]).sensor


def default_agent(sensor: SensorConfig) -> str:
    """The bundled agent `--planner agent` uses with `sensor` (`DEFAULT_AGENTS`).

    Raises:
        ValueError: If none was trained with it, naming the sensor and the bundled ones'.
    """
    for name in DEFAULT_AGENTS:
        if trained_with(_bundled_sensor(name), sensor):
            return name
    trained = "; ".join(f"{name}: {describe_sensor(_bundled_sensor(name))}"
                        for name in DEFAULT_AGENTS)
    raise ValueError(f"no bundled agent was trained with this run's sensor "
                     f"({describe_sensor(sensor)}); the bundled ones were: {trained}; train one "
                     f"for it and give agent:PATH")


def _shapes(space: gym.Space) -> Any:
    """The observation shape: a tuple, or a dict of them for a Dict space."""
    if isinstance(space, gym.spaces.Dict):
        return {key: item.shape for key, item in space.spaces.items()}
    return space.shape


@functools.lru_cache(maxsize=4)
def _load(model_file: Path, modified: int, shown: Path) -> TrainedAgent:
    # Cached per file and modification time: an evaluation asks for the agent every episode.
    # `shown` is the file as the user named it, for the messages.
    config = _run_config(model_file, shown)
    try:
        settings = _settings(model_file)
    except Exception as error:  # a corrupt zip raises anything from zipfile to json
        raise _unloadable(shown, config, error) from None
    replacements = _unpickled(settings, config, shown)
    try:
        model = ALGORITHMS[config.agent.algorithm].load(model_file, device="cpu",
                                                        custom_objects=replacements)
    except Exception as error:  # a corrupt zip raises anything from zipfile to torch
        raise _unloadable(shown, config, error) from None
    trained_on = _recorded_shapes(settings.get("observation_space"))
    expected = _shapes(observation_space(config))
    if trained_on is not None and expected != trained_on:
        raise ValueError(f"agent {shown}: its run's config.yaml gives observations of shape "
                         f"{expected}, but the model was trained on {trained_on}; use the "
                         f"model with the config.yaml of its own run")
    return TrainedAgent(model, config, model_file)


def _unloadable(shown: Path, config: Config, error: Exception) -> ValueError:
    return ValueError(f"agent {shown} cannot be loaded as a {config.agent.algorithm} model "
                      f"({type(error).__name__}: {error})")


class _Spaces(gym.Env):
    """An env with a run's spaces and nothing else: what a model is built against."""

    def __init__(self, config: Config):
        self.observation_space = observation_space(config)
        self.action_space = ActionMapping(config.env, config.sensor.working_distance_m).space


def _settings(model_file: Path) -> dict[str, Any]:
    """The JSON settings (`data`) of a stable-baselines3 model file, nothing unpickled."""
    with zipfile.ZipFile(model_file) as archive:
        settings = json.loads(archive.read("data"))
    if not isinstance(settings, dict):
        raise TypeError(f"its data is a {type(settings).__name__}, not an object")
    return settings


def _unpickled(settings: Mapping[str, Any], config: Config, shown: Path) -> dict[str, Any]:
    """What replaces each pickled setting: the value of the model the run's config builds.

    Raises:
        ValueError: For a pickled setting such a model does not have, naming it.
    """
    pickled = [key for key, value in settings.items()
               if isinstance(value, dict) and ":serialized:" in value]
    built = vars(build_model(config, _Spaces(config), 0, "cpu"))
    unknown = [key for key in pickled if key not in built]
    if unknown:
        raise ValueError(f"agent {shown}: its model file holds pickled settings a "
                         f"{config.agent.algorithm} model of its run does not have "
                         f"({', '.join(unknown)[:200]}); vprobot does not unpickle them, since "
                         f"that runs code (docs/security.md)")
    return {key: built[key] for key in pickled}


def _recorded_shapes(space: Any) -> Any:
    """The observation shape a model file's settings record in readable JSON beside the pickled
    space (a tuple, or a dict of them for a Dict space); None if they do not."""
    if not isinstance(space, dict):
        return None
    if isinstance(space.get("_shape"), list):
        return tuple(space["_shape"])
    # A Dict space's JSON holds its spaces as their repr: "{'mask': Box(0.0, 1.0, (128,), ...".
    if isinstance(space.get("spaces"), str):
        shapes = re.findall(r"'(\w+)': Box\([^()]*\((\d+(?:, \d+)*),?\)", space["spaces"])
        if shapes:
            return {key: tuple(int(size) for size in sizes.split(", ")) for key, sizes in shapes}
    return None
