"""Scoring a policy on fixed episodes (the shared evaluation list), deterministic by default."""

from __future__ import annotations

import statistics
import time
from collections.abc import Sequence
from typing import Any

from stable_baselines3.common.base_class import BaseAlgorithm

from vprobot.config import Config, replace
from vprobot.env import InspectEnv
from vprobot.episode import EpisodeSpec
from vprobot.kinematics import TRAVEL_COSTS

SUMMARY_KEYS = ("coverage", "acquisitions", "success", "reachable_share", "ms_per_view",
                *(f"travel_sum_{name}" for name in TRAVEL_COSTS))


def evaluation_env(config: Config) -> InspectEnv:
    """The env an agent is scored in: its own settings, at the sensor's full resolution."""
    return InspectEnv(replace(config, "env", resolution=None))


def evaluate_policy(model: BaseAlgorithm, env: InspectEnv, specs: Sequence[EpisodeSpec],
                    deterministic: bool = True) -> list[dict[str, Any]]:
    """Run the policy on every spec; one row per episode.

    A row holds coverage, acquisitions (the initial view included), success (coverage goal),
    the reachable share of the requested views, travel between the views (k_cum, four costs)
    and the policy's compute time per view (ms).
    """
    rows = []
    goal = env.config.env.coverage_goal
    for spec in specs:
        observation, info = env.reset(options={"episode": spec})
        done, thinking, requests = False, 0.0, 0
        while not done:
            start = time.perf_counter()
            action, _ = model.predict(observation, deterministic=deterministic)
            thinking += time.perf_counter() - start
            observation, _, terminated, truncated, info = env.step(action)
            done, requests = terminated or truncated, requests + 1
        rows.append({
            "motor": spec.motor, "seed": spec.seed, "coverage": info["coverage"],
            "acquisitions": info["acquisitions"], "success": info["coverage"] >= goal,
            "reachable_share": info["reachable_share"],
            "ms_per_view": 1e3 * thinking / requests,
            **{f"travel_sum_{name}": info[f"travel_sum_{name}"] for name in TRAVEL_COSTS},
        })
    return rows


def summarize(rows: Sequence[dict[str, Any]]) -> dict[str, float]:
    """Means over episodes of the `SUMMARY_KEYS`."""
    return {key: statistics.fmean(float(row[key]) for row in rows) for key in SUMMARY_KEYS}
