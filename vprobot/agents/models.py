"""The stable-baselines3 model a run's config builds: SAC or PPO with the profile's encoder and
regression MLP, or DQN choosing among candidate views, each checked against the env's spaces.

Training builds its fresh model here, and loading a trained agent builds one too, whose values
stand in for the settings a model file holds pickled (`vprobot.agents.trained`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from stable_baselines3 import PPO, SAC
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv

from vprobot.agents.candidate_q import CandidateDQN, check_candidate_spaces
from vprobot.agents.encoders import ENCODERS, check_encoder, network_arguments
from vprobot.agents.extractors import split_space
from vprobot.config import AgentConfig, Config, ConfigError


class LinearSchedule:
    """Learning rate decaying linearly from `initial` to 0 over the run (paper Table 4)."""

    def __init__(self, initial: float):
        self.initial = initial

    def __call__(self, progress_remaining: float) -> float:
        return self.initial * progress_remaining



def check_spaces(agent: AgentConfig, observation_space: gym.Space,
                 action_space: gym.Space) -> None:
    """Raise ConfigError unless the algorithm can act in an env of these spaces: DQN in one
    that chooses among candidate views, SAC and PPO in one with a continuous action and a
    point-cloud state."""
    if agent.algorithm == "dqn":
        check_candidate_spaces(observation_space, action_space)
        return
    try:
        split_space(observation_space)
        continuous = isinstance(action_space, gym.spaces.Box)
    except ValueError:
        continuous = False
    if not continuous:
        raise ConfigError(f"agent.algorithm {agent.algorithm} needs a continuous action and a "
                          f"point-cloud state, got action space {action_space} and observation "
                          f"space {observation_space}; an env choosing among candidate views "
                          f"(env.action: A_view) needs agent.algorithm dqn with agent.encoder "
                          f"candidates")


def build_model(config: Config, env: gym.Env | VecEnv, seed: int, device: str) -> BaseAlgorithm:
    """A fresh model: SAC or PPO with the profile's encoder (its features extractor) and
    regression MLP, or DQN with the encoder's policy (`candidates`: `vprobot.agents.candidate_q`).

    Raises:
        ConfigError: If the encoder is not registered or does not serve the algorithm
            (`check_encoder`), or the algorithm cannot act in the env's spaces (`check_spaces`).
    """
    agent = config.agent
    check_encoder(agent)
    check_spaces(agent, env.observation_space, env.action_space)
    rate: Any = (LinearSchedule(agent.learning_rate) if agent.learning_rate_schedule == "linear"
                 else agent.learning_rate)
    encoder = ENCODERS[agent.encoder]
    if agent.algorithm == "dqn":
        return CandidateDQN(encoder.network, env, learning_rate=rate, gamma=agent.gamma,
                            batch_size=agent.batch_size, buffer_size=agent.buffer_size,
                            learning_starts=agent.learning_starts, train_freq=agent.train_freq,
                            gradient_steps=agent.gradient_steps,
                            target_update_interval=agent.target_update_interval,
                            exploration_fraction=agent.exploration_fraction,
                            exploration_initial_eps=agent.exploration_initial_eps,
                            exploration_final_eps=agent.exploration_final_eps,
                            policy_kwargs=network_arguments(agent), seed=seed, device=device)
    policy = "MultiInputPolicy" if config.env.robot_state else "MlpPolicy"
    policy_kwargs = {"features_extractor_class": encoder.network,
                     "features_extractor_kwargs": network_arguments(agent),
                     "net_arch": list(agent.net_arch)}
    if agent.algorithm == "sac":
        return SAC(policy, env, learning_rate=rate, gamma=agent.gamma,
                   batch_size=agent.batch_size, buffer_size=agent.buffer_size,
                   learning_starts=agent.learning_starts, train_freq=agent.train_freq,
                   gradient_steps=agent.gradient_steps, policy_kwargs=policy_kwargs,
                   seed=seed, device=device)
    return PPO(policy, env, learning_rate=rate, gamma=agent.gamma, n_steps=agent.n_steps,
               batch_size=agent.batch_size, n_epochs=agent.n_epochs,
               policy_kwargs=policy_kwargs, seed=seed, device=device)
