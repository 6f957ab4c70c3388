"""R12 of the paper's Table 3 (sparse): COV_T / (T k_cum) at the last step."""

from vprobot.rewards.base import REWARDS, RewardFormula

R12 = REWARDS.register("R12", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage / (steps * travel_sum),
    uses_travel=True))
