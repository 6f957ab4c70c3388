"""R6 of the paper's Table 3 (dense): dCOV_t / (COV_rem k_t)."""

from vprobot.rewards.base import REWARDS, RewardFormula

R6 = REWARDS.register("R6", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining / travel,
    uses_travel=True))
