"""R5 of the paper's Table 3 (dense): dCOV_t / k_t."""

from vprobot.rewards.base import REWARDS, RewardFormula

R5 = REWARDS.register("R5", RewardFormula(
    True, lambda delta, remaining, travel: delta / travel, uses_travel=True))
