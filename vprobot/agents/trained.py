"""Loading a trained agent: the bundled one, a run directory or a checkpoint file."""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

from stable_baselines3 import PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm

from vprobot.agents.training import load_run_config
from vprobot.config import Config
from vprobot.paths import ASSETS_DIR

BUNDLED_AGENT = ASSETS_DIR / "agents" / "cpu"
"""The agent vprobot ships: trained with `configs/agents/cpu.yaml` (see its README)."""
RUN_MODELS = ("best_model.zip", "final_model.zip", "model.zip")
"""What a directory offers, in order of preference."""


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


def _model_file(source: Path) -> Path:
    if source.is_dir():
        for name in RUN_MODELS:
            if (source / name).is_file():
                return source / name
        raise ValueError(f"agent {source}: no {', '.join(RUN_MODELS)} in the folder; is it a "
                         f"training run?")
    if source.is_file():
        return source
    raise ValueError(f"agent {source} does not exist (give a run directory or a model .zip)")


def _run_config(model_file: Path) -> Config:
    """The config of the run a model file belongs to: beside it, or in a folder above it."""
    for folder in (model_file.parent, *model_file.parents[:3]):
        if (folder / "config.yaml").is_file():
            return load_run_config(folder)
    raise ValueError(f"agent {model_file}: no config.yaml of its run beside it or above it")


def load_agent(source: str | Path | None = None) -> TrainedAgent:
    """Load an agent for planning on the CPU; no network access, no GPU needed.

    Args:
        source: A run directory (its best model), a model .zip inside a run, or None for the
            bundled agent.

    Raises:
        ValueError: For a missing path, a folder without a model, a model whose run config is
            missing, or a file that is not a loadable model.
    """
    model_file = _model_file(Path(source) if source is not None else BUNDLED_AGENT).resolve()
    return _load(model_file, model_file.stat().st_mtime_ns)


@functools.lru_cache(maxsize=4)
def _load(model_file: Path, modified: int) -> TrainedAgent:
    # Cached per file and modification time: an evaluation asks for the agent every episode.
    config = _run_config(model_file)
    algorithm = SAC if config.agent.algorithm == "sac" else PPO
    try:
        model = algorithm.load(model_file, device="cpu")
    except Exception as error:  # a corrupt zip raises anything from zipfile to pickle
        raise ValueError(f"agent {model_file} cannot be loaded as a {config.agent.algorithm} "
                         f"model ({type(error).__name__}: {error})") from None
    return TrainedAgent(model, config, model_file)
