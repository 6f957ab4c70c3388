"""Training benchmark: env and training throughput of the CPU profile, that of the candidate-view
profile with one env and with two env processes, the cost of one gradient step of the CPU and of
the paper profile, and both buffers in bytes."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
from tqdm import tqdm

from vprobot.config import Config, replace
from vprobot.env.actions import ActionMapping
from vprobot.env.inspect_env import InspectEnv
from vprobot.env.observations import observation_space
from vprobot.files.paths import PROFILES_DIR
from vprobot.training.train import buffer_memory, build_model, make_vec_env, profile_config


class SpacesOnly(gym.Env):
    """An env with a profile's spaces and random samples: fills a buffer in no time."""

    def __init__(self, config: Config):
        self.observation_space = observation_space(config)
        size = ActionMapping(config.env, config.sensor.working_distance_m).size
        self.action_space = gym.spaces.Box(-1.0, 1.0, (size,), dtype=np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple:
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action: np.ndarray) -> tuple:
        return self.observation_space.sample(), 0.0, False, False, {}


def update_ms(config: Config, steps: int) -> float:
    """Median time of one gradient step at the profile's batch size (ms)."""
    agent = config.agent
    # Collect a batch without training (learning starts after it), then time single steps.
    config = replace(config, "agent", buffer_size=agent.batch_size + 8,
                     learning_starts=agent.batch_size + 8)
    model = build_model(config, SpacesOnly(config), seed=0, device="cpu")
    model.learn(agent.batch_size + 4)
    # The CPU and the paper profile train SAC, which takes gradient steps of a batch size.
    assert isinstance(model, OffPolicyAlgorithm)
    times = []
    for _ in range(steps):
        start = time.perf_counter()
        model.train(gradient_steps=1, batch_size=agent.batch_size)
        times.append((time.perf_counter() - start) * 1e3)
    return float(np.median(times))


def training_rate(config: Config, envs: int, steps: int, progress: bool) -> float:
    """Env steps per second of training (updates included) with `envs` env processes, after a
    first batch is collected; no pretraining."""
    agent = config.agent
    config = replace(config, "agent", learning_starts=0, n_envs=envs,
                     buffer_size=steps + agent.batch_size + 8 * envs)
    vec = make_vec_env(config, 0, [0] * envs, None)
    model = build_model(config, vec, seed=0, device="cpu")
    model.learn(agent.batch_size)  # fill a batch before timing
    start = time.perf_counter()
    model.learn(steps, reset_num_timesteps=False, progress_bar=progress)
    rate = steps / (time.perf_counter() - start)
    vec.close()
    return rate


def run_train_benchmark(config: Config, steps: int = 300, paper_updates: int = 1,
                        progress: bool = True) -> dict[str, Any]:
    """Measure the CPU profile (`configs/agents/cpu.yaml`), the candidate-view profile
    (`cpu-candidates.yaml`, one env and two env processes: what the second core buys) and the
    paper profile.

    `config` supplies the cell, sensor and kinematics; the profiles their env and agent
    sections. Torch runs on the profile's threads (one).
    """
    cpu, candidates, paper = (
        dataclasses.replace(config, env=profile.env, agent=profile.agent)
        for profile in (profile_config(PROFILES_DIR / name)
                        for name in ("cpu.yaml", "cpu-candidates.yaml", "paper.yaml")))
    torch.set_num_threads(cpu.agent.torch_threads)
    env = InspectEnv(cpu)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    start = time.perf_counter()
    for _ in tqdm(range(steps), desc="env steps", disable=not progress, leave=False):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        if terminated or truncated:
            env.reset()
    env_rate = steps / (time.perf_counter() - start)
    return {
        "env_steps_per_s": env_rate,
        "train_steps_per_s": training_rate(cpu, 1, steps, progress),
        "candidates_train_steps_per_s_1_env": training_rate(candidates, 1, steps, progress),
        "candidates_train_steps_per_s_2_envs": training_rate(candidates, 2, steps, progress),
        "update_ms_cpu": update_ms(cpu, 20),
        "update_ms_paper": update_ms(paper, paper_updates),
        "buffer_bytes_cpu": buffer_memory(cpu)["total_bytes"],
        "buffer_bytes_per_transition_cpu": buffer_memory(cpu)["bytes_per_transition"],
        "buffer_bytes_paper": buffer_memory(paper)["total_bytes"],
        "buffer_bytes_per_transition_paper": buffer_memory(paper)["bytes_per_transition"],
        "steps": steps,
        "torch_threads": cpu.agent.torch_threads,
    }

