"""R1 of the paper's Table 3 (dense): dCOV_t."""

from vprobot.rewards.base import REWARDS, RewardFormula

R1 = REWARDS.register("R1", RewardFormula(
    True, lambda delta, remaining, travel: delta))
