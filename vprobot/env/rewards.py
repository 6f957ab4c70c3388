"""How the environment pays the rewards of `vprobot.rewards.REWARDS`
(docs/states-actions-rewards.md#rewards): a step's reward from its formula, travel costs in
divisions and COV_rem floored at `travel_cost_floor`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from vprobot.rewards import REWARDS

if TYPE_CHECKING:
    from vprobot.config import EnvConfig


def step_limit(env: EnvConfig) -> int:
    """Requests an episode may make after its initial view: `goal_only_step_cap` with a reward
    that ends only at the goal, else `max_acquisitions`."""
    return env.goal_only_step_cap if REWARDS[env.reward].goal_only else env.max_acquisitions


@dataclasses.dataclass(frozen=True)
class RewardTerms:
    """What one step's reward is made of (reported in `info`)."""

    reward: float
    delta_coverage: float
    remaining_coverage_before: float
    travel_cost: float
    penalty: float
    stop: float = 0.0


class Reward:
    """One reward variant.

    Args:
        name: A name in `REWARDS` (R1 to R14).
        travel_cost_floor: Lower bound of k_t and k_cum in divisions (> 0).
        unreachable_penalty: Added to the reward of a step whose request was unreachable.

    Raises:
        ValueError: If the name is unknown or the floor is not positive.
    """

    def __init__(self, name: str, travel_cost_floor: float,
                 unreachable_penalty: float = 0.0):
        self.formula = REWARDS[name]
        if not travel_cost_floor > 0:
            raise ValueError(f"travel_cost_floor must be > 0, got {travel_cost_floor}")
        self.name = name
        self.floor = travel_cost_floor
        self.unreachable_penalty = unreachable_penalty

    @property
    def goal_only(self) -> bool:
        return self.formula.goal_only

    def _dense(self, delta: float, remaining_before: float, travel: float) -> float:
        if self.formula.no_gain_penalty and delta <= 0.0:
            return -1.0
        # Floored too: the last step can leave no coverage to gain before it.
        return self.formula.value(delta, max(remaining_before, self.floor),
                                  max(travel, self.floor))

    def _sparse(self, final_coverage: float, steps: int, travel_sum: float) -> float:
        return self.formula.value(final_coverage, max(steps, 1), max(travel_sum, self.floor))

    def step(self, delta: float, remaining_before: float, travel: float, reachable: bool,
             episode_over: bool, goal_reached: bool, final_coverage: float, steps: int,
             travel_sum: float) -> RewardTerms:
        """Reward of one step.

        Args:
            delta: Coverage gain of the step (0 for an unreachable request).
            remaining_before: 1 - coverage before the step.
            travel: Travel cost k_t of the step.
            reachable: Whether the requested view was reached.
            episode_over: Whether this is the episode's last step (T).
            goal_reached: Whether the coverage goal is reached (R13/R14 pay only then).
            final_coverage: Coverage after this step (COV_T when episode_over).
            steps: Steps so far including this one (T when episode_over).
            travel_sum: Sum of the travel costs so far including this step (k_cum).
        """
        if self.formula.dense:
            value = self._dense(delta, remaining_before, travel)
        elif not episode_over:
            value = 0.0
        elif self.goal_only and not goal_reached:
            value = 0.0
        else:
            value = self._sparse(final_coverage, steps, travel_sum)
        penalty = 0.0 if reachable else self.unreachable_penalty
        return RewardTerms(value + penalty, delta, remaining_before, travel, penalty)
