"""Rewards R1-R14 of the paper's Table 3 (docs/states-actions-rewards.md#rewards).

Dense rewards are paid every step from the coverage gain dCOV_t, the remaining coverage before
the step COV_rem and the travel cost k_t; sparse rewards pay 0 until the episode's last step T
and then a function of the final coverage COV_T, T and the summed travel k_cum. Travel costs in
divisions are floored at `travel_cost_floor`.
"""

from __future__ import annotations

import dataclasses

from vprobot.config import EnvConfig, RewardName

DENSE: tuple[str, ...] = ("R1", "R2", "R3", "R4", "R5", "R6", "R7", "R8")
SPARSE: tuple[str, ...] = ("R9", "R10", "R11", "R12", "R13", "R14")
GOAL_ONLY: tuple[str, ...] = ("R13", "R14")
"""Rewards whose episodes end only at the coverage goal (with a safety cap)."""


def step_limit(env: EnvConfig) -> int:
    """Requests an episode may make after its initial view: `goal_only_step_cap` with a reward
    that ends only at the goal, else `max_acquisitions`."""
    return env.goal_only_step_cap if env.reward in GOAL_ONLY else env.max_acquisitions


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
        name: R1 to R14.
        travel_cost_floor: Lower bound of k_t and k_cum in divisions (> 0).
        unreachable_penalty: Added to the reward of a step whose request was unreachable.

    Raises:
        ValueError: If the name is unknown or the floor is not positive.
    """

    def __init__(self, name: RewardName, travel_cost_floor: float,
                 unreachable_penalty: float = 0.0):
        if name not in DENSE + SPARSE:
            raise ValueError(f"unknown reward {name!r}; allowed: {list(DENSE + SPARSE)}")
        if not travel_cost_floor > 0:
            raise ValueError(f"travel_cost_floor must be > 0, got {travel_cost_floor}")
        self.name = name
        self.floor = travel_cost_floor
        self.unreachable_penalty = unreachable_penalty

    @property
    def goal_only(self) -> bool:
        return self.name in GOAL_ONLY

    def _dense(self, delta: float, remaining_before: float, travel: float) -> float:
        travel = max(travel, self.floor)
        # Floored too: the last step can leave no coverage to gain before it.
        remaining = max(remaining_before, self.floor)
        gain = {
            "R1": delta,
            "R2": delta,
            "R3": delta / remaining,
            "R4": delta / remaining,
            "R5": delta / travel,
            "R6": delta / remaining / travel,
            "R7": delta / travel,
            "R8": delta / remaining / travel,
        }[self.name]
        if self.name in ("R2", "R4", "R7", "R8") and delta <= 0.0:
            return -1.0
        return gain

    def _sparse(self, final_coverage: float, steps: int, travel_sum: float) -> float:
        travel_sum = max(travel_sum, self.floor)
        steps = max(steps, 1)
        return {
            "R9": final_coverage,
            "R10": final_coverage / steps,
            "R11": final_coverage / travel_sum,
            "R12": final_coverage / (steps * travel_sum),
            "R13": 1.0 / steps,
            "R14": 1.0 / (steps * travel_sum),
        }[self.name]

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
        if self.name in DENSE:
            value = self._dense(delta, remaining_before, travel)
        elif not episode_over:
            value = 0.0
        elif self.goal_only and not goal_reached:
            value = 0.0
        else:
            value = self._sparse(final_coverage, steps, travel_sum)
        penalty = 0.0 if reachable else self.unreachable_penalty
        return RewardTerms(value + penalty, delta, remaining_before, travel, penalty)
