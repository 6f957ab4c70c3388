"""DQN over a fixed set of candidate views (`agent.algorithm: dqn`, `agent.encoder: candidates`).

The env offers K candidate views: its action is `Discrete(K)` and its observation a Dict of
`candidates` (K, F), one feature row per candidate, `mask` (K,), 1 where the candidate may be
requested, and optionally `robot` (n,), the robot state. The Q-network applies one shared MLP to
every candidate row, concatenated with a context pooled over all rows (mean and max of a
per-row embedding): permuting the rows permutes the Q-values, so what is learned about a view
does not depend on its index and carries over to other candidate sets.

A masked candidate is never chosen: its Q-value is `MASKED_Q` (so the greedy action and the
bootstrapped target's maximum are over allowed candidates), and exploration, both before
`learning_starts` and epsilon-greedy after it, draws uniformly among the allowed candidates.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import DQN
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.preprocessing import preprocess_obs
from stable_baselines3.common.torch_layers import create_mlp
from stable_baselines3.common.type_aliases import PyTorchObs
from stable_baselines3.dqn.policies import DQNPolicy
from torch import nn

from vprobot.config import ConfigError

CANDIDATES_KEY = "candidates"
MASK_KEY = "mask"
ROBOT_KEY = "robot"
MASKED_Q = -1e9
"""Q-value of a candidate that may not be requested: below any value a reward can give, finite
so that a target computed from it stays finite."""


def check_candidate_spaces(observation_space: gym.Space, action_space: gym.Space) -> int:
    """Raise ConfigError unless the spaces are those of a candidate-view env.

    Returns:
        The width of a candidate's row as `CandidateQNetwork` reads it: its features, its mask
        entry and the robot state when there is one.

    Raises:
        ConfigError: Naming the settings that give such an env.
    """
    spaces = observation_space.spaces if isinstance(observation_space, gym.spaces.Dict) else {}
    if (isinstance(action_space, gym.spaces.Discrete)
            and {CANDIDATES_KEY, MASK_KEY} <= set(spaces) <= {CANDIDATES_KEY, MASK_KEY, ROBOT_KEY}):
        # A space without a shape (a Dict) has none of the shapes asked for.
        shape = spaces[CANDIDATES_KEY].shape or ()
        robot = (spaces[ROBOT_KEY].shape or ()) if ROBOT_KEY in spaces else (0,)
        if (len(shape) == 2 and spaces[MASK_KEY].shape == shape[:1]
                and action_space.n == shape[0] and len(robot) == 1):
            return shape[1] + 1 + robot[0]
    raise ConfigError(f"agent.algorithm dqn needs an env that chooses among candidate views "
                      f"(env.action: A_view, env.state: s_grid: a Discrete(K) action and a "
                      f"Dict of 'candidates' (K, F) and 'mask' (K,)), got action space "
                      f"{action_space} and observation space {observation_space}")


def allowed_rows(mask: torch.Tensor) -> torch.Tensor:
    """Booleans (batch, K): the allowed candidates; every one in a row that allows none (a state
    the env should have ended), so that its values and targets stay finite."""
    allowed = mask > 0.5
    return allowed | ~allowed.any(dim=1, keepdim=True)


class CandidateQNetwork(BasePolicy):
    """Q-values (batch, K) of the candidate views, masked.

    The input of row k is its features, its mask entry (so the pooled context knows which views
    are taken or unreachable) and the robot state when there is one. A first layer of width
    `net_arch[0]` embeds every row; the mean and the max of the embeddings over the rows are the
    context; the MLP of widths `net_arch` maps each row's input and the context to its Q-value.
    With `views_left`, a second network of the same shape but with parameters of its own (an
    embedding of every row, pooled by mean and max, and an MLP of widths `net_arch`) maps the
    rows to the number of views the state still needs to reach the goal (`views_left`, fitted
    beside a cover's membership, `vprobot.training.pretrain`); the Q-values do not read it, and
    fitting it leaves them as they would be without it.

    Args:
        observation_space: A Dict of `candidates`, `mask` and optionally `robot`.
        action_space: Discrete(K).
        net_arch: Hidden widths of the per-row MLP.
        views_left: Whether the network has the head of the views left.

    Raises:
        ConfigError: For spaces that are not those of a candidate-view env.
    """

    def __init__(self, observation_space: gym.Space, action_space: gym.Space,
                 net_arch: list[int], views_left: bool = False):
        width = check_candidate_spaces(observation_space, action_space)
        super().__init__(observation_space, action_space)
        self.net_arch = list(net_arch)
        self.embedding = nn.Sequential(nn.Linear(width, self.net_arch[0]), nn.ReLU())
        self.head = nn.Sequential(*create_mlp(width + 2 * self.net_arch[0], 1, self.net_arch))
        self.views_left_head = _PooledRows(width, self.net_arch) if views_left else None

    def _rows(self, observation: PyTorchObs) -> tuple[torch.Tensor, torch.Tensor]:
        """Every row's input (batch, K, width) and the mask (batch, K)."""
        obs = preprocess_obs(observation, self.observation_space)
        # The Dict space (check_candidate_spaces) preprocesses to a dict.
        assert isinstance(obs, dict)
        candidates, mask = obs[CANDIDATES_KEY], obs[MASK_KEY]
        count = candidates.shape[1]
        parts = [candidates, mask.unsqueeze(2)]
        if ROBOT_KEY in obs:
            parts.append(obs[ROBOT_KEY].unsqueeze(1).expand(-1, count, -1))
        return torch.cat(parts, dim=2), mask

    def forward(self, observation: PyTorchObs) -> torch.Tensor:
        rows, mask = self._rows(observation)
        count = rows.shape[1]
        context = _pooled(self.embedding(rows))
        values = self.head(torch.cat([rows, context.unsqueeze(1).expand(-1, count, -1)], dim=2))
        return values.squeeze(2).masked_fill(~allowed_rows(mask), MASKED_Q)

    def log_views_left(self, observation: PyTorchObs) -> torch.Tensor:
        """The logarithm of the views each state still needs to reach the goal (batch,): what
        the head outputs, fitted in logs since the views left run from 1 to a few tens.

        Raises:
            ValueError: For a network built without the head.
        """
        if self.views_left_head is None:
            raise ValueError("this network has no head of the views left (it is built for "
                             "agent.pretrain_target cover or views)")
        return self.views_left_head(self._rows(observation)[0])

    def views_left(self, observation: PyTorchObs) -> torch.Tensor:
        """The views each state still needs to reach the goal (batch,), `log_views_left`'s
        exponential.

        Raises:
            ValueError: For a network built without the head.
        """
        return self.log_views_left(observation).exp()

    def _predict(self, observation: PyTorchObs,
                 deterministic: bool = True) -> torch.Tensor:
        return self(observation).argmax(dim=1).reshape(-1)


def _pooled(embedded: torch.Tensor) -> torch.Tensor:
    """The mean and the max of the rows' embeddings (batch, 2 width), a row order's invariant."""
    return torch.cat([embedded.mean(dim=1), embedded.max(dim=1).values], dim=1)


class _PooledRows(nn.Module):
    """One number per state from its rows: an embedding of every row, pooled (`_pooled`), then an
    MLP of widths `net_arch`."""

    def __init__(self, width: int, net_arch: list[int]):
        super().__init__()
        self.embedding = nn.Sequential(nn.Linear(width, net_arch[0]), nn.ReLU())
        self.mlp = nn.Sequential(*create_mlp(2 * net_arch[0], 1, net_arch))

    def forward(self, rows: torch.Tensor) -> torch.Tensor:
        return self.mlp(_pooled(self.embedding(rows))).squeeze(1)


class CandidatePolicy(DQNPolicy):
    """DQN's policy (Q-network, target network, optimiser) with `CandidateQNetwork`s: they read
    the Dict observation themselves, with no features extractor. `views_left` gives them the head
    of the views left."""

    def __init__(self, *args: Any, views_left: bool = False, **kwargs: Any):
        self.views_left = views_left  # read by make_q_net, which DQNPolicy's __init__ calls
        super().__init__(*args, **kwargs)

    # SB3 annotates its own QNetwork; DQN only calls the network and its parameters.
    def make_q_net(self) -> CandidateQNetwork:  # type: ignore[override]
        return CandidateQNetwork(self.observation_space, self.action_space,
                                 self.net_arch, self.views_left).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "views_left": self.views_left}


class CandidateDQN(DQN):
    """Stable-baselines3's DQN whose exploration draws only allowed candidates.

    Give it `CandidatePolicy` (its greedy action is always an allowed candidate).
    """

    def random_actions(self, observation: np.ndarray | dict[str, np.ndarray] | None,
                       ) -> np.ndarray:
        """Uniform draws among each observation's allowed candidates (among all of them where
        none is allowed), from the action space's seeded generator; batched like the input.

        Raises:
            TypeError: For an observation that is not a candidate-view env's dict.
        """
        if not isinstance(observation, dict):
            raise TypeError(f"a candidate-view observation is a dict, got {observation!r}")
        masks = np.asarray(observation[MASK_KEY]) > 0.5
        batch = masks.reshape(-1, masks.shape[-1])
        batch = batch | ~batch.any(axis=1, keepdims=True)
        actions = np.array([self.action_space.sample(mask=row.astype(np.int8)) for row in batch])
        return actions if masks.ndim == 2 else actions[0]

    def predict(self, observation: np.ndarray | dict[str, np.ndarray],
                state: tuple[np.ndarray, ...] | None = None,
                episode_start: np.ndarray | None = None,
                deterministic: bool = False) -> tuple[np.ndarray, tuple[np.ndarray, ...] | None]:
        """Epsilon-greedy as DQN's, the random action drawn among the allowed candidates (the
        coin and the draw both from the action space's seeded generator)."""
        if not deterministic and self.action_space.np_random.random() < self.exploration_rate:
            return self.random_actions(observation), state
        return self.policy.predict(observation, state, episode_start, deterministic)

    def _sample_action(self, learning_starts: int, action_noise: Any = None,
                       n_envs: int = 1) -> tuple[np.ndarray, np.ndarray]:
        # Before `learning_starts` SB3 draws from the whole action space: draw allowed ones.
        if self.num_timesteps < learning_starts:
            actions = self.random_actions(self._last_obs)
            return actions, actions
        return super()._sample_action(learning_starts, action_noise, n_envs)
