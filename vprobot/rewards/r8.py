"""R8 of the paper's Table 3 (dense): dCOV_t / (COV_rem k_t), -1 for a step that gains nothing."""

from vprobot.rewards.base import REWARDS, RewardFormula

R8 = REWARDS.register("R8", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining / travel,
    uses_travel=True, no_gain_penalty=True))
