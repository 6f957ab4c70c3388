"""The encoders' networks, one module each, registering itself in
`vprobot.agents.encoders.ENCODERS` (which declares them and imports one on the first lookup of
its name): the
point-cloud feature extractors of `sac` and `ppo` (stable-baselines3's `BaseFeaturesExtractor`,
on `base.PointCloudExtractor`) and DQN's `candidates` policy.

| name (module) | encoder |
|---|---|
| `pcn` | the paper's PCN: shared MLP 3->128->256, max-pool, concatenate, 512->512->1024, max-pool |
| `pointnet` | PointNet with its input T-Net (identity at initialisation) |
| `sphere` (`sphere_map`) | the CPU-budget encoder: a direction map of the cloud, one linear layer |
| `candidates` | DQN's Q-network, one shared MLP per candidate row |
"""

from vprobot.agents.extractors.base import PointCloudExtractor, split_space

__all__ = ["PointCloudExtractor", "split_space"]
