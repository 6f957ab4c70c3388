"""A reproducible, resumable stream of training episodes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import gymnasium as gym
import numpy as np

from vprobot.episode import sample_episode

if TYPE_CHECKING:
    from vprobot.env.inspect_env import InspectEnv

SEED_BOUND = 2**31


class EpisodeStream(gym.Wrapper):
    """Draws episode k of env `rank` from its own seed (run seed, rank, k), so that a resumed
    run goes on with the episodes an uninterrupted one would have seen.

    Args:
        env: A `vprobot/Inspect-v0` env.
        seed: The run's seed.
        rank: The env's index among the run's parallel envs.
        start: Index of the first episode to draw (the count reached when resuming).
    """

    def __init__(self, env: InspectEnv, seed: int, rank: int = 0, start: int = 0):
        super().__init__(env)
        self.inspect = env
        self.seed_ = seed
        self.rank = rank
        self.episodes_started = start

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        options = dict(options or {})
        if "episode" not in options:
            rng = np.random.default_rng([self.seed_, self.rank, self.episodes_started])
            env = self.inspect.config.env
            options["episode"] = sample_episode(
                env, self.inspect.part_files, rng, seed=int(rng.integers(SEED_BOUND)),
                scale=env.mesh_scale if env.parts == "mesh" else 1.0)
        self.episodes_started += 1
        return self.env.reset(seed=seed, options=options)
