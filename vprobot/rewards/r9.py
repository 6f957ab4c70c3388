"""R9 of the paper's Table 3 (sparse): COV_T at the last step."""

from vprobot.rewards.base import REWARDS, RewardFormula

R9 = REWARDS.register("R9", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage))
