"""What a reward is (`RewardFormula`) and the registry of them (`REWARDS`).

Dense rewards are paid every step from the coverage gain dCOV_t, the remaining coverage before
the step COV_rem and the travel cost k_t; sparse rewards pay 0 until the episode's last step T
and then a function of the final coverage COV_T, T and the summed travel k_cum. A new reward is
a module of this package, declared in `REWARDS` (or a plugin, `vprobot.extensions.plugins`), that
registers one more `RewardFormula` in `REWARDS` (docs/extending.md#reward).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from vprobot.extensions.registry import Bundled, Registry


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


REWARDS: Registry[RewardFormula] = Registry("reward", bundled={
    f"R{number}": Bundled(f"vprobot.rewards.r{number}:R{number}") for number in range(1, 15)})
"""Every reward by name (`env.reward`): R1-R14 of the paper's Table 3, one module each here."""
