"""The base of the point-cloud feature extractors: Box or Dict observations, robot state."""

from __future__ import annotations

import abc
import itertools

import gymnasium as gym
import torch
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn


def shared_mlp(widths: list[int]) -> nn.Sequential:
    """A per-point MLP (1x1 convolutions over points laid out as (batch, channels, points))."""
    layers: list[nn.Module] = []
    for width_in, width_out in itertools.pairwise(widths):
        layers += [nn.Conv1d(width_in, width_out, 1), nn.ReLU()]
    return nn.Sequential(*layers)


class PointCloudExtractor(BaseFeaturesExtractor, abc.ABC):
    """Encodes the `points` observation (N, C) and appends the `robot` entry when there is one.

    Subclasses implement `encode` on points laid out as (batch, N, C). With `s_cov` the points
    are the acquired cloud only (the model-free premise); with `s_bin` they carry a 0/1 covered
    column.

    Args:
        observation_space: A Box (N, C), or a Dict with `points` (N, C) and `robot` (R,).
        encoded_dim: Size of the point encoding.

    Raises:
        ValueError: For any other observation space.
    """

    def __init__(self, observation_space: gym.Space, encoded_dim: int):
        points, robot = split_space(observation_space)
        robot_dim = 0 if robot is None else int(robot.shape[0])
        super().__init__(observation_space, encoded_dim + robot_dim)
        self.points_shape = tuple(points.shape)
        self.columns = int(points.shape[1])

    @abc.abstractmethod
    def encode(self, points: torch.Tensor) -> torch.Tensor:
        """(batch, N, C) points -> (batch, encoded_dim) features."""

    def forward(self, observations: torch.Tensor | dict[str, torch.Tensor]) -> torch.Tensor:
        if isinstance(observations, dict):
            return torch.cat([self.encode(observations["points"]), observations["robot"]],
                             dim=1)
        return self.encode(observations)


def split_space(space: gym.Space) -> tuple[gym.spaces.Box, gym.spaces.Box | None]:
    """The points Box and the robot-state Box (None) of an observation space.

    Raises:
        ValueError: If the space is neither a Box (N, C) nor a Dict of `points` and `robot`.
    """
    if isinstance(space, gym.spaces.Box) and len(space.shape) == 2:
        return space, None
    if isinstance(space, gym.spaces.Dict) and set(space.spaces) == {"points", "robot"}:
        points, robot = space["points"], space["robot"]
        if isinstance(points, gym.spaces.Box) and isinstance(robot, gym.spaces.Box):
            return points, robot
    raise ValueError(f"point-cloud extractors take a Box (N, C) or a Dict of 'points' and "
                     f"'robot', got {space}")
