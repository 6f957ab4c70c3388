"""R4 of the paper's Table 3 (dense): dCOV_t / COV_rem, -1 for a step that gains nothing."""

from vprobot.rewards.base import REWARDS, RewardFormula

R4 = REWARDS.register("R4", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining,
    no_gain_penalty=True))
