"""Rewards R1-R14 of the paper's Table 3 (docs/states-actions-rewards.md#rewards).

Dense rewards are paid every step from the coverage gain dCOV_t, the remaining coverage before
the step COV_rem and the travel cost k_t; sparse rewards pay 0 until the episode's last step T
and then a function of the final coverage COV_T, T and the summed travel k_cum. Travel costs in
divisions are floored at `travel_cost_floor`. A new reward is one more `RewardFormula` registered
in `REWARDS`, from any module imported before the config names it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING

from vprobot.registry import Registry

if TYPE_CHECKING:
    from vprobot.config import EnvConfig


@dataclasses.dataclass(frozen=True)
class RewardFormula:
    """One reward variant.

    Attributes:
        dense: Paid every step from (dCOV_t, COV_rem, k_t); else only at the last step, from
            (COV_T, T, k_cum).
        value: The formula of those three arguments (the travel costs and COV_rem floored).
        uses_travel: Whether it divides by a travel cost (so that the config refuses a
            joint-space cost without the robot).
        no_gain_penalty: A dense step that gains no coverage pays -1 instead.
        goal_only: Episodes end only at the coverage goal (with a safety cap), and the sparse
            reward is paid only there.
    """

    dense: bool
    value: Callable[[float, float, float], float]
    uses_travel: bool = False
    no_gain_penalty: bool = False
    goal_only: bool = False


REWARDS: Registry[RewardFormula] = Registry("reward")
"""Every reward by name (`env.reward`), in registration order."""

REWARDS.register("R1", RewardFormula(True, lambda delta, remaining, travel: delta))
REWARDS.register("R2", RewardFormula(True, lambda delta, remaining, travel: delta,
                                     no_gain_penalty=True))
REWARDS.register("R3", RewardFormula(True, lambda delta, remaining, travel: delta / remaining))
REWARDS.register("R4", RewardFormula(True, lambda delta, remaining, travel: delta / remaining,
                                     no_gain_penalty=True))
REWARDS.register("R5", RewardFormula(True, lambda delta, remaining, travel: delta / travel,
                                     uses_travel=True))
REWARDS.register("R6", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining / travel, uses_travel=True))
REWARDS.register("R7", RewardFormula(True, lambda delta, remaining, travel: delta / travel,
                                     uses_travel=True, no_gain_penalty=True))
REWARDS.register("R8", RewardFormula(
    True, lambda delta, remaining, travel: delta / remaining / travel, uses_travel=True,
    no_gain_penalty=True))
REWARDS.register("R9", RewardFormula(False, lambda coverage, steps, travel_sum: coverage))
REWARDS.register("R10", RewardFormula(False, lambda coverage, steps, travel_sum: coverage / steps))
REWARDS.register("R11", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage / travel_sum, uses_travel=True))
REWARDS.register("R12", RewardFormula(
    False, lambda coverage, steps, travel_sum: coverage / (steps * travel_sum),
    uses_travel=True))
REWARDS.register("R13", RewardFormula(False, lambda coverage, steps, travel_sum: 1.0 / steps,
                                      goal_only=True))
REWARDS.register("R14", RewardFormula(
    False, lambda coverage, steps, travel_sum: 1.0 / (steps * travel_sum), uses_travel=True,
    goal_only=True))


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
