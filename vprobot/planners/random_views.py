"""Random next-best-view agents NBV1^rand and NBV2^rand (paper Table 5).

Each step draws a uniform action in [-1, 1]^n and maps it with the environment's action mapping
(`vprobot.env.actions`): NBV1^rand uses A_3S2R with the npk radius (0 to 1 m) and absolute Euler
angles, NBV2^rand uses A_3S0R looking at the centre with the radius over the sensor's operating
range [near, far] (the paper's [30, 50] cm). Like the agents they start from the environment's
initial view and run until the goal or the view budget.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from vprobot.config import Config, EnvConfig
from vprobot.env.actions import ActionMapping
from vprobot.episode import Episode, ViewRequest
from vprobot.planners.base import Planner, register_planner
from vprobot.planners.initial_view import InitialViewPlanner


class RandomPlanner(InitialViewPlanner):
    """Uniformly random actions of one action variant.

    Args:
        env: Environment config giving the action variant and its ranges.
        working_distance_m: The sensor's optimal distance (fixed radius of some variants).
        roll_free: Leave the roll of non-look-at views to the IK.
    """

    def __init__(self, env: EnvConfig, working_distance_m: float, roll_free: bool):
        self.mapping = ActionMapping(env, working_distance_m)
        self.roll_free = roll_free
        self._rng = np.random.default_rng(0)

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._rng = rng

    def next_view(self, episode: Episode) -> ViewRequest | None:
        action = self._rng.uniform(-1.0, 1.0, self.mapping.size)
        return ViewRequest(self.mapping.target(action, episode.center, self.roll_free))


@register_planner
class Random1Planner(RandomPlanner):
    """NBV1^rand: A_3S2R, npk radius, absolute orientation."""

    name = "random1"
    evaluated = ("random1",)

    def __init__(self, config: Config):
        env = dataclasses.replace(config.env, action="A_3S2R", position_mapping="npk")
        super().__init__(env, config.sensor.working_distance_m, config.kinematics.roll == "free")

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        return cls(config)


@register_planner
class Random2Planner(RandomPlanner):
    """NBV2^rand: A_3S0R looking at the centre, radius over the sensor's range."""

    name = "random2"
    evaluated = ("random2",)

    def __init__(self, config: Config):
        sensor = config.sensor
        env = dataclasses.replace(config.env, action="A_3S0R", position_mapping="npk",
                                  radius_range_m=(sensor.near_m, sensor.far_m))
        super().__init__(env, sensor.working_distance_m, config.kinematics.roll == "free")

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        return cls(config)
