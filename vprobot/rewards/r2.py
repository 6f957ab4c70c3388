"""R2 of the paper's Table 3 (dense): dCOV_t, -1 for a step that gains nothing."""

from vprobot.rewards.base import REWARDS, RewardFormula

R2 = REWARDS.register("R2", RewardFormula(
    True, lambda delta, remaining, travel: delta,
    no_gain_penalty=True))
