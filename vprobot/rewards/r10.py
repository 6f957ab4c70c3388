"""R10 of the paper's Table 3 (sparse): COV_T / T at the last step."""

from vprobot.rewards.base import REWARDS, RewardFormula

R10 = REWARDS.register("R10", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage / steps))
