"""Greedy model-based next-best-view: an upper reference for next-best-view agents.

Like the agents, the oracle starts from the environment's initial view and picks one view at a
time from what has been measured so far; unlike them it knows the object model: it takes the
usable candidate (`candidates`) that adds the most uncovered GT points (predicted, then
confirmed by a simulated acquisition), until the goal or the view budget. With the robot it
only offers views the robot reaches from where it is.
"""

from __future__ import annotations

import numpy as np

from vprobot.episode import Episode, ViewRequest
from vprobot.planners.base import register_planner
from vprobot.planners.candidates import CANDIDATE_COUNT, ModelBasedPlanner, candidate_views
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.visibility import DEFAULT_RESOLUTION


@register_planner
class OraclePlanner(InitialViewPlanner, ModelBasedPlanner):
    """Greedy next-best-view on the candidates' predicted visibility.

    Args:
        candidate_count: Candidate positions on the view sphere.
        resolution: Grid of the visibility renderer.
    """

    name = "oracle"
    evaluated = ("oracle",)

    def __init__(self, candidate_count: int = CANDIDATE_COUNT,
                 resolution: tuple[int, int] = DEFAULT_RESOLUTION):
        self.candidate_count = candidate_count
        self.resolution = resolution
        self._taken: set[int] = set()

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self.candidates = candidate_views(episode, self.candidate_count, self.resolution)
        self._taken = set()

    def next_view(self, episode: Episode) -> ViewRequest | None:
        if self.candidates is None:
            raise RuntimeError("call reset() before next_view()")
        best = self.candidates.next_best(episode, self._taken)
        if best is None:
            return None
        self._taken.add(best)
        return self.candidates.request(best)
