"""B_SCP: greedy set cover over the candidate views (paper "Comparison with benchmark algorithms").

The plan repeatedly takes the usable candidate that sees the most GT points no chosen view sees
yet, `views` times (B_SCP,n) or until the coverage goal. Visibility is predicted for all
candidates and confirmed by a simulated acquisition (`Episode.preview`) before a candidate is
taken (`greedy.greedy_cover`, at most `CONFIRMATIONS_PER_PICK` per pick), so the plan's
coverage is what its views measure.
The chosen views are then ordered for short travel (`ordering.order_requests`). When the goal
was the criterion and the executed plan still falls short (e.g. a view whose joint-space path
collided had to be taken from another configuration), the planner keeps adding the greedy next
view on the measured coverage until the goal or the view budget is reached.
"""

from __future__ import annotations

from typing import ClassVar

from vprobot.config import Config
from vprobot.episode import Episode, ViewRequest
from vprobot.planners.base import Planner, PlanPlanner, check_views, register_planner
from vprobot.planners.candidates import (
    CANDIDATE_COUNT,
    CONFIRMATIONS_PER_PICK,
    ModelBasedPlanner,
    candidate_views,
)
from vprobot.planners.greedy import greedy_cover
from vprobot.planners.ordering import order_requests
from vprobot.planners.self_stopping import SelfStopping
from vprobot.planners.visibility import DEFAULT_RESOLUTION


@register_planner
class SetCoverPlanner(ModelBasedPlanner, SelfStopping, PlanPlanner):
    """B_SCP over the usable candidates.

    Args:
        views: Fixed number of views (B_SCP,n); None plans until the coverage goal.
        goal: Coverage goal when `views` is None.
        max_views: View budget when planning to the goal.
        candidate_count: Candidate positions on the view sphere.
        resolution: Grid of the visibility renderer.

    Attributes:
        picks: The candidates of the plan in greedy order (before ordering for travel).
        gains: GT points each pick added (measured by its simulated acquisition).

    Raises:
        ValueError: If views is not in 1..MAX_VIEWS, max_views is < 1, or the goal is outside
            (0, 1].
    """

    name = "bscp"
    counted = True
    evaluated: ClassVar[tuple[str, ...]] = ("bscp", "bscp4", "bscp5")

    def __init__(self, views: int | None = None, goal: float = 0.9, max_views: int = 10,
                 candidate_count: int = CANDIDATE_COUNT,
                 resolution: tuple[int, int] = DEFAULT_RESOLUTION):
        super().__init__()
        if views is not None:
            check_views(views)
        if max_views < 1:
            raise ValueError(f"max_views must be >= 1, got {max_views}")
        if not 0.0 < goal <= 1.0:
            raise ValueError(f"goal must lie in (0, 1], got {goal}")
        self.views = views
        self.goal = goal
        self.max_views = max_views
        self.candidate_count = candidate_count
        self.resolution = resolution
        self.stops_at_goal = views is None
        self.picks: list[int] = []
        self.gains: list[int] = []
        self._taken: set[int] = set()

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        return cls(views, goal=config.env.coverage_goal, max_views=config.env.max_acquisitions)

    def plan(self, episode: Episode) -> list[ViewRequest]:
        candidates = candidate_views(episode, self.candidate_count, self.resolution)
        self.candidates = candidates
        count = self.views if self.views is not None else self.max_views
        goal = None if self.views is not None else self.goal
        self.picks, self.gains = greedy_cover(
            candidates.known_visibility(), episode.covered, count, goal,
            confirm=lambda i: candidates.measured(i, episode),
            confirmations=CONFIRMATIONS_PER_PICK)
        self._taken = set(self.picks)
        return order_requests(episode, [candidates.request(i) for i in self.picks])

    def next_view(self, episode: Episode) -> ViewRequest | None:
        view = super().next_view(episode)
        if view is not None or self.views is not None or self.candidates is None:
            return view
        best = self.candidates.next_best(episode, self._taken)
        if best is None:
            return None
        self._taken.add(best)
        return self.candidates.request(best)
