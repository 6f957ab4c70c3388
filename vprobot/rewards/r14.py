"""R14 of the paper's Table 3 (sparse): 1 / (T k_cum), paid only at the coverage goal."""

from vprobot.rewards.base import REWARDS, RewardFormula

R14 = REWARDS.register("R14", RewardFormula(
    False, lambda coverage, steps, travel_sum: 1.0 / (steps * travel_sum),
    uses_travel=True, goal_only=True))
