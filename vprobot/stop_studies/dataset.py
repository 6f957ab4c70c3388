"""Rollouts that teach the coverage estimate: the features and the true coverage after each view.

Model-free planners (`DEFAULT_PLANNERS`) run with the robot in the loop on episodes of split v1
(`vprobot.parts.splits`): drawn from its training objects for fitting, its validation list for model
selection and the reported error; never a test list. The coverage goal is lifted during the
rollouts, so that planners the simulator would stop at the goal go on to the view budget and
the data holds views past the goal too, as a stop rule meets them.

A table of rollouts is written an episode at a time, so that a run cut short keeps the episodes
it finished and a rerun goes on from them; a record beside it (`record_recipe`) says how they
were drawn, so that rollouts of other settings are never taken for these.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from vprobot.config import Config, replace
from vprobot.coverage.occupancy import EpisodeGrid, GridSettings
from vprobot.episode import (
    Episode,
    EpisodeSpec,
    PartScene,
    ViewRecord,
    read_episode_list,
    seeded_episode,
)
from vprobot.episode.specs import bundled_episode_list, part_name
from vprobot.files.atomic import (
    append_line,
    csv_text,
    read_table,
    refuse_link,
    truncate_output,
    write_text,
)
from vprobot.parts.generated import family_of
from vprobot.parts.splits import MOTORS, Split
from vprobot.planners.runner import make_planner, run_episode
from vprobot.stopping.features import FEATURES, episode_features
from vprobot.stopping.rules import make_stop_rule

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
        episodes: (n,) the number of the row's episode in its table.
    """

    features: np.ndarray
    coverage: np.ndarray
    views: np.ndarray
    planners: np.ndarray
    families: np.ndarray
    episodes: np.ndarray

    def select(self, rows: np.ndarray) -> Dataset:
        """The rows a boolean mask (n,) keeps."""
        return Dataset(*(getattr(self, field.name)[rows] for field in dataclasses.fields(self)))


def rollout_config(config: Config) -> Config:
    """The config of the rollouts: no coverage goal (planners run to the view budget)."""
    return replace(config, "env", coverage_goal=1.0)


def _family(name: str) -> str:
    """The part family of an object as the tables name it (`motor` for a motor)."""
    return family_of(name) or "motor"


def _draw(objects: Sequence[str | Path], count: int, seed: int
          ) -> tuple[np.ndarray, np.ndarray]:
    """The objects (indices) and the pose seeds of `count` training episodes drawn from `seed`."""
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(objects), size=count, replace=count > len(objects))
    return chosen, rng.integers(0, 2**31 - 1, size=count)


def _missing_families(objects: Sequence[str | Path], chosen: np.ndarray,
                      families: Sequence[str]) -> list[str]:
    """The families of which the chosen objects hold none."""
    drawn = {_family(part_name(objects[index])) for index in chosen}
    return [family for family in families if family not in drawn]


def training_jobs(config: Config, count: int, seed: int,
                  planners: Sequence[str] = DEFAULT_PLANNERS,
                  split: Split | None = None) -> list[tuple[EpisodeSpec, str]]:
    """`count` episodes on the split's training objects (every source equally likely), each
    with one planner in turn, drawn from `seed`.

    Raises:
        ValueError: If count < 1, no planner is given, or the draw holds no object of a
            training family (`stop fit` leaves each out in turn, which needs its episodes).
    """
    if count < 1 or not planners:
        raise ValueError(f"training rollouts need count >= 1 and a planner, got {count} and "
                         f"{list(planners)}")
    split = split if split is not None else Split.load()
    objects = split.training_objects((MOTORS, *split.training_families))
    chosen, poses = _draw(objects, count, seed)
    missing = _missing_families(objects, chosen, split.training_families)
    if missing:
        # Draws of other counts are other draws: the least one that holds every family.
        least = next(more for more in itertools.count(count + 1) if not _missing_families(
            objects, _draw(objects, more, seed)[0], split.training_families))
        raise ValueError(f"--episodes {count} with --seed {seed} draws no training episode of "
                         f"family {', '.join(missing)} (each training family is left out in "
                         f"turn and needs episodes of its own); --episodes {least} is the "
                         f"least count that draws every family with this seed")
    return [(seeded_episode(config.env, objects[index], int(pose)),
             planners[number % len(planners)])
            for number, (index, pose) in enumerate(zip(chosen, poses, strict=True))]


def validation_jobs(planners: Sequence[str] = DEFAULT_PLANNERS,
                    split: Split | None = None) -> list[tuple[EpisodeSpec, str]]:
    """Every planner on every episode of the split's validation list."""
    split = split if split is not None else Split.load()
    specs = read_episode_list(bundled_episode_list(split.validation_list))
    return [(spec, planner) for spec in specs for planner in planners]


def rollout_recipe(config: Config, planners: Sequence[str], **drawn: Any) -> dict[str, Any]:
    """How rollouts are drawn, as JSON reads it back: `drawn` (their episodes), the settings
    they run with (the rollout config's cell, sensor, kinematics and env: not the coverage goal,
    which they lift, nor the agent's), the planners and the features."""
    settings = rollout_config(config)
    return json.loads(json.dumps({
        **drawn, "planners": list(planners), "features": list(FEATURES),
        "settings": {section: dataclasses.asdict(getattr(settings, section))
                     for section in ("cell", "sensor", "kinematics", "env")}}))


def drawn_alike(record: Path, recipe: Mapping[str, Any]) -> bool:
    """Whether the rollouts that `record` describes were drawn as `recipe` says (False: there
    is no record).

    Raises:
        ValueError: If they were drawn otherwise.
    """
    if not record.is_file():
        return False
    if json.loads(record.read_text()) != recipe:
        raise ValueError(f"{record.parent} holds rollouts drawn otherwise ({record}); use "
                         f"another --out")
    return True


def record_recipe(record: Path, recipe: Mapping[str, Any], tables: Sequence[Path]) -> None:
    """Remove `tables`, which no record describes (an older version's), and record how their
    rollouts are drawn from now on."""
    for table in tables:
        table.unlink(missing_ok=True)
    write_text(record, json.dumps(recipe, indent=1) + "\n")


def rollout(config: Config, spec: EpisodeSpec, planner: str) -> list[dict[str, Any]]:
    """One episode of `planner` (robot in the loop, no coverage goal): per view, its number,
    features and true coverage."""
    settings = rollout_config(config)
    scene = PartScene.load(settings, spec.part_path, spec.scale)
    views, grid = play(settings, scene, planner, spec)
    return [{"view": view, **dict(zip(FEATURES, features.tolist(), strict=True)),
             "coverage": views[view - 1].coverage}
            for view, features in enumerate(episode_features(config, views, grid), start=1)]


def play(config: Config, scene: PartScene, planner: str, spec: EpisodeSpec
         ) -> tuple[list[ViewRecord], EpisodeGrid]:
    """One episode of `planner` with the robot in the loop, as `vprobot.planners.runner.run`
    plays it: its views, and the episode's grid of the features, which a grid planner (nbv)
    has filled as it went (each acquired frame is integrated once)."""
    episode = Episode.from_spec(scene, spec, "robot", config.env.unreachable)
    played = run_episode(make_planner(planner, config), episode, spec, config,
                         np.random.default_rng(spec.seed), make_stop_rule("goal", config))
    return list(played.record.views), episode.occupancy(GridSettings.of(config))


def finished_episodes(path: Path) -> set[int]:
    """The episodes whose rows `path` holds; a write cut short by a kill is cut from the file
    with the other rows of its episode, so that appending goes on cleanly.

    Raises:
        ValueError: If the file is not a table of `COLUMNS` (`LinkError`: or a symbolic link
            that it would cut).
    """
    if not path.is_file():
        return set()
    data = path.read_bytes()
    lines = data.splitlines(keepends=True)
    torn = bool(lines) and not lines[-1].endswith(b"\n")
    if torn:
        lines.pop()
    if lines and lines[0].decode().rstrip("\r\n") != ",".join(COLUMNS):
        raise ValueError(f"{path} is not a coverage-estimate dataset (its columns differ from "
                         f"{', '.join(COLUMNS)}); use another --out")
    episodes = [int(line.split(b",", 1)[0]) for line in lines[1:]]
    if torn and episodes:
        # The cut line may belong to the last episode seen: drop that episode whole.
        last = episodes[-1]
        while episodes and episodes[-1] == last:
            episodes.pop()
    kept = sum(len(line) for line in lines[:1 + len(episodes)])
    if kept < len(data):
        truncate_output(path, kept)
    return set(episodes)


def collect(config: Config, jobs: Sequence[tuple[EpisodeSpec, str]], path: Path,
            progress: bool = True) -> int:
    """Run the jobs that `path` lacks (robot in the loop, no coverage goal), appending each
    episode's rows (one per view) as it ends.

    Returns:
        The episodes run.

    Raises:
        ValueError: If `path` is not a table of `COLUMNS` (`LinkError`: or a symbolic link).
    """
    refuse_link(path)  # before any rollout: they would be appended into a file outside
    done = finished_episodes(path)
    missing = [number for number in range(len(jobs)) if number not in done]
    try:
        for number in tqdm(missing, desc=path.stem, disable=not progress):
            spec, planner = jobs[number]
            rows = [{"episode": number, "object": spec.part, "family": _family(spec.part),
                     "planner": planner, "seed": spec.seed, **row}
                    for row in rollout(config, spec, planner)]
            # One write per episode: a kill leaves whole episodes and at worst a cut last one.
            append_line(path, csv_text(COLUMNS, rows,
                                       header=not path.exists() or path.stat().st_size == 0))
    except KeyboardInterrupt:
        print(f"kept {len(finished_episodes(path))} of {len(jobs)} rollouts in {path}; run "
              f"the same command again to go on", file=sys.stderr)
        raise
    return len(missing)


def read_dataset(path: str | Path) -> Dataset:
    """Read a table written from `collect`'s rows.

    Raises:
        ValueError: If the file is missing, its columns are not `COLUMNS`, or a row is damaged
            (cells missing, or a value that does not parse), naming the file and the row.
    """
    path = Path(path)
    try:
        columns, rows = read_table(path)
    except OSError as error:
        raise ValueError(f"cannot read dataset {path}: {error}") from None
    if tuple(columns) != COLUMNS:
        raise ValueError(f"{path} is not a coverage-estimate dataset (its columns differ from "
                         f"{', '.join(COLUMNS)})")
    numeric = (*FEATURES, "coverage", "view")
    table = np.empty((len(rows), len(numeric)))
    for number, row in enumerate(rows, start=1):
        for column, name in enumerate(numeric):
            try:
                table[number - 1, column] = float(row[name])
            except ValueError:
                raise ValueError(f"{path}, row {number}: {name} is not a number") from None
    return Dataset(features=table[:, :len(FEATURES)], coverage=table[:, -2],
                   views=table[:, -1].astype(int),
                   planners=np.array([row["planner"] for row in rows]),
                   families=np.array([row["family"] for row in rows]),
                   episodes=np.array([int(row["episode"]) for row in rows], dtype=int))
