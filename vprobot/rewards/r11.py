"""R11 of the paper's Table 3 (sparse): COV_T / k_cum at the last step."""

from vprobot.rewards.base import REWARDS, RewardFormula

R11 = REWARDS.register("R11", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage / travel_sum,
    uses_travel=True))
