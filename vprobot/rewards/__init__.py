"""The rewards by name (`env.reward`, docs/states-actions-rewards.md#rewards): `REWARDS`, one
module per reward, each registering its `RewardFormula` (`base`).

A low layer: it imports only the registry, so that the config checks `env.reward` against it
without bringing the environment, which pays the rewards (`vprobot.env.rewards`).
"""

from vprobot.rewards.base import REWARDS, RewardFormula

__all__ = ["REWARDS", "RewardFormula"]
