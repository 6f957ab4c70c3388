"""Scoring a policy on fixed episodes (the shared evaluation list), deterministic by default.

Each episode gives the row `vprobot evaluate` writes (`vprobot.evaluation.episode_row`) and the
episodes are summarized by its `summarize`: a training's evaluations and the evaluation tables
have the same columns, units and definitions.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from stable_baselines3.common.base_class import BaseAlgorithm

from vprobot.config import Config, replace
from vprobot.env.inspect_env import InspectEnv
from vprobot.episode import EpisodeSpec
from vprobot.episode.clearances import episode_clearances
from vprobot.evaluation import (
    COLUMNS,
    OPTIMUM_COLUMNS,
    PROOF_SUMMARY_COLUMNS,
    episode_row,
    summarize,
)
from vprobot.planners.runner import EpisodeResult

SUMMARY_KEYS = tuple(key for key in COLUMNS if key not in ("planner", "carrier", *OPTIMUM_COLUMNS,
                                                           *PROOF_SUMMARY_COLUMNS))
"""The columns of a policy's summary: `vprobot evaluate`'s table without planner and carrier,
and without the comparison with the optimum and its proofs (a policy is scored alone)."""
POLICY = "policy"
"""The planner column of a policy's episode rows."""


def evaluation_env(config: Config) -> InspectEnv:
    """The env an agent is scored in: its own settings, at the sensor's full resolution."""
    return InspectEnv(replace(config, "env", resolution=None))


def evaluate_policy(model: BaseAlgorithm, env: InspectEnv, specs: Sequence[EpisodeSpec],
                    deterministic: bool = True) -> list[dict[str, Any]]:
    """Run the policy on every spec; one `episode_row` per episode, its planning time the
    policy's compute."""
    rows = []
    for index, spec in enumerate(specs):
        start = time.perf_counter()
        observation, _ = env.reset(options={"episode": spec})
        done, thinking = False, 0.0
        while not done:
            before = time.perf_counter()
            action, _ = model.predict(observation, deterministic=deterministic)
            thinking += time.perf_counter() - before
            observation, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
        assert env.episode is not None  # reset made it
        record = env.episode.record()
        rows.append(episode_row(index, EpisodeResult(
            planner=POLICY, carrier=env.config.env.carrier, spec=spec, record=record,
            goal=env.config.env.coverage_goal, plan_seconds=thinking,
            episode_seconds=time.perf_counter() - start,
            clearances=episode_clearances(record, env.episode.scene.cell))))
    return rows


def policy_summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The summary (`vprobot.evaluation.summarize`) of one policy's rows.

    Raises:
        ValueError: For no rows.
    """
    if not rows:
        raise ValueError("a policy's summary needs at least one episode")
    (table_row,) = summarize(list(rows))
    return {key: table_row[key] for key in SUMMARY_KEYS}
