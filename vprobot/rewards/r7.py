"""R7 of the paper's Table 3 (dense): dCOV_t / k_t, -1 for a step that gains nothing."""

from vprobot.rewards.base import REWARDS, RewardFormula

R7 = REWARDS.register("R7", RewardFormula(
    True, lambda delta, remaining, travel: delta / travel, uses_travel=True,
    no_gain_penalty=True))
