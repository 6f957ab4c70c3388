"""Rollouts that teach the coverage estimate: the features and the true coverage after each view.

Model-free planners (`DEFAULT_PLANNERS`) run with the robot in the loop on episodes of split v1
(`vprobot.splits`): drawn from its training objects for fitting, its validation list for model
selection and the reported error; never a test list. The coverage goal is lifted during the
rollouts, so that planners the simulator would stop at the goal go on to the view budget and
the data holds views past the goal too, as a stop rule meets them.
"""

from __future__ import annotations

import csv
import dataclasses
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from vprobot.config import Config, replace
from vprobot.episode import EpisodeSpec, MotorScene, read_episode_list, seeded_episode
from vprobot.episode.specs import bundled_episode_list
from vprobot.generated import family_of
from vprobot.planners.runner import run
from vprobot.splits import MOTORS, Split
from vprobot.stopping.features import FEATURES, episode_features

DEFAULT_PLANNERS = ("random2", "uniform4", "uniform6", "uniform8", "nbv")
"""Planners of the rollouts: random, fixed patterns of several sizes, next-best view."""
COLUMNS = ("episode", "object", "family", "planner", "seed", "view", *FEATURES, "coverage")


@dataclasses.dataclass(frozen=True)
class Dataset:
    """Rows of (episode, view): features and the true coverage.

    Attributes:
        features: (n, len(FEATURES)).
        coverage: (n,) the true coverage after the view.
        views: (n,) views requested so far (1 is the first).
        planners: (n,) the planner of the row's episode.
        families: (n,) the part family of the row's object (`motor` for a motor).
    """

    features: np.ndarray
    coverage: np.ndarray
    views: np.ndarray
    planners: np.ndarray
    families: np.ndarray

    def select(self, rows: np.ndarray) -> Dataset:
        """The rows a boolean mask (n,) keeps."""
        return Dataset(*(getattr(self, field.name)[rows] for field in dataclasses.fields(self)))


def rollout_config(config: Config) -> Config:
    """The config of the rollouts: no coverage goal (planners run to the view budget)."""
    return replace(config, "env", coverage_goal=1.0)


def training_jobs(config: Config, count: int, seed: int,
                  planners: Sequence[str] = DEFAULT_PLANNERS,
                  split: Split | None = None) -> list[tuple[EpisodeSpec, str]]:
    """`count` episodes on the split's training objects (every source equally likely), each
    with one planner in turn, drawn from `seed`.

    Raises:
        ValueError: If count < 1 or no planner is given.
    """
    if count < 1 or not planners:
        raise ValueError(f"training rollouts need count >= 1 and a planner, got {count} and "
                         f"{list(planners)}")
    split = split if split is not None else Split.load()
    objects = split.training_objects((MOTORS, *split.training_families))
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(objects), size=count, replace=count > len(objects))
    poses = rng.integers(0, 2**31 - 1, size=count)
    return [(seeded_episode(config.env, objects[index], int(pose)),
             planners[number % len(planners)])
            for number, (index, pose) in enumerate(zip(chosen, poses, strict=True))]


def validation_jobs(planners: Sequence[str] = DEFAULT_PLANNERS,
                    split: Split | None = None) -> list[tuple[EpisodeSpec, str]]:
    """Every planner on every episode of the split's validation list."""
    split = split if split is not None else Split.load()
    specs = read_episode_list(bundled_episode_list(split.validation_list))
    return [(spec, planner) for spec in specs for planner in planners]


def collect(config: Config, jobs: Sequence[tuple[EpisodeSpec, str]],
            progress: bool = True) -> list[dict[str, Any]]:
    """Run the jobs (robot in the loop, no coverage goal); one row per view."""
    rollout = rollout_config(config)
    rows: list[dict[str, Any]] = []
    for number, (spec, planner) in enumerate(tqdm(jobs, desc="rollouts", disable=not progress)):
        scene = MotorScene.load(rollout, spec.motor_path, spec.scale)
        views = run(rollout, scene, planner, spec, "robot").record.views
        for view, features in enumerate(episode_features(config, views), start=1):
            rows.append({"episode": number, "object": spec.motor,
                         "family": family_of(spec.motor) or "motor", "planner": planner,
                         "seed": spec.seed, "view": view,
                         **dict(zip(FEATURES, features.tolist(), strict=True)),
                         "coverage": views[view - 1].coverage})
    return rows


def read_dataset(path: str | Path) -> Dataset:
    """Read a table written from `collect`'s rows.

    Raises:
        ValueError: If the file is missing or its columns are not `COLUMNS`.
    """
    try:
        with Path(path).open(newline="") as stream:
            reader = csv.DictReader(stream)
            if tuple(reader.fieldnames or ()) != COLUMNS:
                raise ValueError(f"{path} is not a coverage-estimate dataset (its columns "
                                 f"differ from {', '.join(COLUMNS)})")
            rows = list(reader)
    except OSError as error:
        raise ValueError(f"cannot read dataset {path}: {error}") from None
    return Dataset(
        features=np.array([[float(row[name]) for name in FEATURES] for row in rows]
                          ).reshape(len(rows), len(FEATURES)),
        coverage=np.array([float(row["coverage"]) for row in rows]),
        views=np.array([int(row["view"]) for row in rows]),
        planners=np.array([row["planner"] for row in rows]),
        families=np.array([row["family"] for row in rows]))
