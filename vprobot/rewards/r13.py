"""R13 of the paper's Table 3 (sparse): 1 / T, paid only at the coverage goal."""

from vprobot.rewards.base import REWARDS, RewardFormula

R13 = REWARDS.register("R13", RewardFormula(
    False, lambda coverage, steps, travel_sum: 1.0 / steps, goal_only=True))
