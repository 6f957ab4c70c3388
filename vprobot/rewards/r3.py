"""R3 of the paper's Table 3 (dense): dCOV_t / COV_rem."""

from vprobot.rewards.base import REWARDS, RewardFormula

R3 = REWARDS.register("R3", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining))
