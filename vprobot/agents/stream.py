"""A reproducible, resumable stream of training episodes."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from vprobot.episode import sample_episode

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

    def __init__(self, env: gym.Env, seed: int, rank: int = 0, start: int = 0):
        super().__init__(env)
        self.seed_ = seed
        self.rank = rank
        self.episodes_started = start

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        options = dict(options or {})
        if "episode" not in options:
            inspect = self.env.unwrapped
            rng = np.random.default_rng([self.seed_, self.rank, self.episodes_started])
            env = inspect.config.env
            options["episode"] = sample_episode(
                env, inspect.motor_files, rng, seed=int(rng.integers(SEED_BOUND)),
                scale=env.mesh_scale if env.motors == "mesh" else 1.0)
        self.episodes_started += 1
        return self.env.reset(seed=seed, options=options)
