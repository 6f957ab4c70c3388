"""Environment benchmark: steps per second at full and training resolution (robot in the loop,
and the free-flying sensor at the training resolution), reset time, and the candidate-view env
the agents of the realistic cell learn in (`s_grid` state, `A_view` actions, the robot, the
training resolution; issue 45's target: >= 20 steps/s in that cell)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import SubprocVecEnv
from tqdm import tqdm

from vprobot.cell.sensor import TRAINING_RESOLUTION
from vprobot.config import Config, replace
from vprobot.env.inspect_env import InspectEnv
from vprobot.extensions import plugins

BENCHMARK_ENV = {"action": "A_3S2R_lim", "reward": "R2", "parts": "train"}
GRID_ENV = {"state": "s_grid", "action": "A_view", "reward": "R2", "parts": "train"}


def _steps_per_second(env: InspectEnv, steps: int, seed: int, progress: bool,
                      label: str) -> tuple[float, list[float]]:
    """Random actions for `steps` steps (resets excluded); also returns the reset times."""
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    stepping, resets = 0.0, []
    for _ in tqdm(range(steps), desc=label, disable=not progress, leave=False):
        action: int | np.ndarray
        if isinstance(observation, dict) and "mask" in observation:
            # A candidate the state offers, at random.
            action = int(rng.choice(np.flatnonzero(observation["mask"] > 0.5)))
        else:
            action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        start = time.perf_counter()
        observation, _, terminated, truncated, _ = env.step(action)  # type: ignore[arg-type]
        stepping += time.perf_counter() - start
        if terminated or truncated:
            start = time.perf_counter()
            observation, _ = env.reset()
            resets.append((time.perf_counter() - start) * 1e3)
    return steps / stepping, resets


def _make_train_env(config: Config) -> InspectEnv:
    return InspectEnv(config)


def run_env_benchmark(config: Config, steps: int = 300, progress: bool = True) -> dict[str, Any]:
    """Measure the environment's throughput with random A_3S2R_lim actions and R2.

    Every training motor is loaded (and its ground truth built or read from the cache) before
    timing, so that resets measure a cached motor. `steps_per_s_free_train` is the free-flying
    sensor (`carrier: free`) at the training resolution; `steps_per_s_grid_train` the
    candidate-view env (`s_grid`, `A_view`, random offered candidates, the robot, the training
    resolution); the reset time is the robot's with the continuous actions.
    """
    full = replace(config, "env", **BENCHMARK_ENV, resolution=None)
    train = replace(config, "env", **BENCHMARK_ENV, resolution=TRAINING_RESOLUTION)
    free = replace(train, "env", carrier="free")
    grid = replace(config, "env", **GRID_ENV, resolution=TRAINING_RESOLUTION)
    results: dict[str, Any] = {}
    resets: list[float] = []
    for name, settings in (("full", full), ("train", train), ("free_train", free),
                           ("grid_train", grid)):
        env = InspectEnv(settings)
        for path in tqdm(env.part_files, desc=f"load motors ({name})", disable=not progress,
                         leave=False):
            env.scene(path)
        rate, reset_ms = _steps_per_second(env, steps, seed=0, progress=progress, label=name)
        results[f"steps_per_s_{name}"] = rate
        if settings.env.carrier == "robot" and name != "grid_train":
            resets += reset_ms
    vec = SubprocVecEnv([plugins.in_child(lambda: _make_train_env(train))] * 2)
    vec.seed(0)
    vec.reset()
    rng = np.random.default_rng(1)
    start = time.perf_counter()
    for _ in tqdm(range(steps // 2), desc="2 processes", disable=not progress, leave=False):
        vec.step(rng.uniform(-1.0, 1.0, (2, *(vec.action_space.shape or ()))).astype(np.float32))
    results["steps_per_s_2proc_train"] = 2 * (steps // 2) / (time.perf_counter() - start)
    vec.close()
    results["reset_ms_median"] = float(np.median(resets))
    results["training_resolution"] = list(TRAINING_RESOLUTION)
    results["steps"] = steps
    return results
