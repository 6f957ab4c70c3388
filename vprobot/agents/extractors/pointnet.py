"""PointNet encoder with its input transform (T-Net)."""

from __future__ import annotations

import gymnasium as gym
import torch
from torch import nn

from vprobot.agents.encoders import ENCODERS, Encoder
from vprobot.agents.extractors.base import PointCloudExtractor, shared_mlp


class InputTransform(nn.Module):
    """T-Net: predicts a 3x3 transform of the coordinates; the identity at initialisation
    (last layer zero, bias the identity), so training starts from the raw points.

    Args:
        columns: Point columns (the first three are coordinates).
        widths: Shared MLP widths, then the two regression widths.
    """

    def __init__(self, columns: int, widths: list[int]):
        super().__init__()
        self.features = shared_mlp([columns, widths[0], widths[1], widths[2]])
        self.regression = nn.Sequential(nn.Linear(widths[2], widths[3]), nn.ReLU(),
                                        nn.Linear(widths[3], widths[4]), nn.ReLU())
        self.transform = nn.Linear(widths[4], 9)
        nn.init.zeros_(self.transform.weight)
        with torch.no_grad():
            self.transform.bias.copy_(torch.eye(3).flatten())

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        """(batch, N, C) -> (batch, 3, 3)."""
        pooled = self.features(points.transpose(1, 2)).max(dim=2).values
        return self.transform(self.regression(pooled)).view(-1, 3, 3)


class PointNetExtractor(PointCloudExtractor):
    """Input T-Net, shared MLP C->64->128->1024, max-pool: 1024 features.

    Args:
        observation_space: Points (N, C), or a Dict with a robot state.
        scale: Multiplies every width (1.0: PointNet's sizes; small values for tests).
    """

    def __init__(self, observation_space: gym.Space, scale: float = 1.0):
        widths = [max(1, round(width * scale)) for width in (64, 128, 1024, 512, 256)]
        super().__init__(observation_space, widths[2])
        self.input_transform = InputTransform(self.columns, widths)
        self.encoder = shared_mlp([self.columns, widths[0], widths[1], widths[2]])

    def encode(self, points: torch.Tensor) -> torch.Tensor:
        coordinates = points[..., :3] @ self.input_transform(points)
        points = torch.cat([coordinates, points[..., 3:]], dim=2)
        return self.encoder(points.transpose(1, 2)).max(dim=2).values


POINTNET = ENCODERS.register("pointnet", Encoder(PointNetExtractor))
