"""Imitation before RL: fit the candidate Q-network to the teacher (`agent.pretrain_episodes`).

The teacher (`vprobot.agents.teacher`) rolls out episodes on the run's training objects,
requesting its best candidate, or with probability `EPSILON` a random allowed one, so that the
states also hold a learner's mistakes. Every state is stored with the values of all candidates,
and the Q-network (and its target) is fitted to them by least squares over the allowed
candidates: a target for every candidate at once, where RL sees one reward per step. DQN then
goes on from there, adding the discounted future to the immediate value.

The episodes come from a stream of their own (`PRETRAIN_RANK`), apart from the RL envs'.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from vprobot.agents.candidate_q import MASK_KEY, CandidateDQN, allowed_rows
from vprobot.agents.stream import EpisodeStream
from vprobot.agents.teacher import CandidateTeacher
from vprobot.config import Config
from vprobot.env.inspect_env import InspectEnv
from vprobot.files import write_text

PRETRAIN_RANK = 1_000
EPSILON = 0.2
PRETRAIN_FILE = "pretrain.csv"
"""Per epoch of the fit: the mean squared error over the allowed candidates."""


@dataclasses.dataclass
class TeacherStates:
    """States of the teacher's episodes and the values of every candidate in each.

    Attributes:
        observations: The env's observations, stacked per key (n, ...).
        values: The teacher's value of every candidate (n, K).
    """

    observations: dict[str, np.ndarray]
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.values)


def collect(config: Config, episodes: int, seed: int, progress: bool = False) -> TeacherStates:
    """Roll out `episodes` teacher episodes on the config's training objects.

    Raises:
        ValueError: If episodes < 1.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    inspect = InspectEnv(config)
    env = EpisodeStream(inspect, seed, PRETRAIN_RANK)
    rng = np.random.default_rng([seed, PRETRAIN_RANK])
    teacher = CandidateTeacher()
    observations: list[dict[str, np.ndarray]] = []
    values: list[np.ndarray] = []
    for _ in tqdm(range(episodes), desc="teacher episodes", disable=not progress):
        observation, _ = env.reset()
        episode = inspect.current_episode()
        # The `s_grid` state screened the candidates' reachability: the teacher reads it.
        grid_state = inspect.observer.grid_state
        teacher.reset(episode, grid_state.screening(episode) if grid_state is not None else None)
        done = False
        while not done:
            value = teacher.values(episode)
            observations.append(observation)
            values.append(value)
            allowed = np.flatnonzero(observation[MASK_KEY] > 0.5)
            if rng.random() < EPSILON:
                action = int(rng.choice(allowed))
            else:
                action = int(allowed[np.argmax(value[allowed])])
            observation, _, terminated, truncated, _ = env.step(action)
            done = terminated or truncated
    env.close()
    stacked = {key: np.stack([obs[key] for obs in observations]) for key in observations[0]}
    return TeacherStates(stacked, np.stack(values).astype(np.float32))


def fit(model: CandidateDQN, states: TeacherStates, epochs: int, seed: int) -> list[float]:
    """Fit the model's Q-network to the teacher's values (Adam at the model's learning rate,
    its batch size), then copy it into the target network. Returns the loss of every epoch."""
    q_net = model.policy.q_net
    optimizer = torch.optim.Adam(q_net.parameters(), lr=model.lr_schedule(1.0))
    rng = np.random.default_rng(seed)
    losses = []
    for _ in range(epochs):
        order = rng.permutation(len(states))
        total = 0.0
        for start in range(0, len(order), model.batch_size):
            batch = order[start:start + model.batch_size]
            obs = {key: torch.as_tensor(value[batch], device=model.device)
                   for key, value in states.observations.items()}
            target = torch.as_tensor(states.values[batch], device=model.device)
            allowed = allowed_rows(obs[MASK_KEY]).float()
            error = (q_net(obs) - target) * allowed
            loss = error.square().sum() / allowed.sum()
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
            total += loss.item() * len(batch)
        losses.append(total / len(order))
    model.policy.q_net_target.load_state_dict(q_net.state_dict())
    return losses


def pretrain(model: CandidateDQN, config: Config, seed: int, run_dir: Path,
             progress: bool = False) -> list[float]:
    """Collect the teacher's states and fit the model to them; the losses go to
    `run_dir/pretrain.csv`."""
    agent = config.agent
    states = collect(config, agent.pretrain_episodes, seed, progress)
    losses = fit(model, states, agent.pretrain_epochs, seed)
    write_text(run_dir / PRETRAIN_FILE, "epoch,mse\n" + "".join(
        f"{epoch},{loss:.6g}\n" for epoch, loss in enumerate(losses, start=1)))
    return losses
