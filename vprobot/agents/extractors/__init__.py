"""Point-cloud feature extractors for stable-baselines3 (`BaseFeaturesExtractor`), the networks
of the encoders of `sac` and `ppo` (registered by name in `vprobot.agents.encoders.ENCODERS`).

| name | encoder |
|---|---|
| `pcn` | the paper's PCN: shared MLP 3->128->256, max-pool, concatenate, 512->512->1024, max-pool |
| `pointnet` | PointNet with its input T-Net (identity at initialisation) |
| `sphere` | the CPU-budget encoder: a direction map of the cloud and a small CNN |
"""

from vprobot.agents.extractors.base import PointCloudExtractor, split_space
from vprobot.agents.extractors.pcn import PCNExtractor
from vprobot.agents.extractors.pointnet import InputTransform, PointNetExtractor
from vprobot.agents.extractors.sphere_map import SphereMapExtractor

__all__ = [
    "InputTransform",
    "PCNExtractor",
    "PointCloudExtractor",
    "PointNetExtractor",
    "SphereMapExtractor",
    "split_space",
]
