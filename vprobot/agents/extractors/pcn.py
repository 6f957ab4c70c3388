"""PCN encoder (the paper's, after the Point Completion Network): two shared MLPs around a
max-pooled global feature."""

from __future__ import annotations

import gymnasium as gym
import torch

from vprobot.agents.encoders import ENCODERS, Encoder
from vprobot.agents.extractors.base import PointCloudExtractor, shared_mlp


class PCNExtractor(PointCloudExtractor):
    """Shared MLP C->128->256, max-pool, the global feature concatenated to every point,
    shared MLP 512->512->1024, max-pool: 1024 features (paper Table 4).

    Args:
        observation_space: Points (N, C), or a Dict with a robot state.
        scale: Multiplies every width (1.0: the paper's sizes; small values for tests).
    """

    def __init__(self, observation_space: gym.Space, scale: float = 1.0):
        widths = [max(1, round(width * scale)) for width in (128, 256, 512, 1024)]
        super().__init__(observation_space, widths[3])
        self.first = shared_mlp([self.columns, widths[0], widths[1]])
        self.second = shared_mlp([2 * widths[1], widths[2], widths[3]])

    def encode(self, points: torch.Tensor) -> torch.Tensor:
        local = self.first(points.transpose(1, 2))
        pooled = local.max(dim=2, keepdim=True).values.expand_as(local)
        return self.second(torch.cat([local, pooled], dim=1)).max(dim=2).values


PCN = ENCODERS.register("pcn", Encoder(PCNExtractor))
