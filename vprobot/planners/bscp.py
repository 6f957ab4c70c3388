"""B_SCP: greedy set cover over the candidate views (paper "Comparison with benchmark algorithms").

The plan repeatedly takes the usable candidate that sees the most GT points no chosen view sees
yet, `views` times (B_SCP,n) or until the predicted coverage reaches the goal. The chosen views
are then ordered for short travel (`ordering.order_requests`). Predicted and measured coverage
differ slightly (the visibility renderer is coarse, executed views are measured at full
resolution, the arm may occlude); when the goal was the criterion and the executed plan falls
short, the planner keeps adding the greedy next view on the measured coverage until the goal or
the view budget is reached.
"""

from __future__ import annotations

import math

import numpy as np

from vprobot.planners.base import Episode, PlanPlanner, ViewRequest
from vprobot.planners.candidates import CANDIDATE_COUNT, CandidateViews, candidate_views
from vprobot.planners.ordering import order_requests
from vprobot.planners.visibility import DEFAULT_RESOLUTION


def greedy_cover(visibility: np.ndarray, covered: np.ndarray, count: int,
                 goal: float | None = None) -> tuple[list[int], list[int]]:
    """Greedy set cover: pick rows of `visibility` that add the most uncovered points.

    Args:
        visibility: Which points each candidate sees (candidates, points).
        covered: Points covered before the first pick (points,).
        count: Largest number of picks.
        goal: Stop once this fraction of the points is covered (None: make `count` picks).

    Returns:
        The picked rows and the points each added (non-increasing: coverage is submodular).
        Picking stops early when no candidate adds anything.

    Raises:
        ValueError: If the shapes disagree or count < 0.
    """
    visibility = np.asarray(visibility, dtype=bool)
    covered = np.array(covered, dtype=bool)
    if visibility.ndim != 2 or covered.shape != (visibility.shape[1],):
        raise ValueError(f"visibility (candidates, points) and covered (points,) disagree: "
                         f"{visibility.shape} and {covered.shape}")
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    needed = math.ceil(goal * len(covered) - 1e-9) if goal is not None else None
    picks: list[int] = []
    gains: list[int] = []
    while len(picks) < count and (needed is None or covered.sum() < needed):
        added = np.count_nonzero(visibility & ~covered, axis=1)
        best = int(np.argmax(added))
        if added[best] == 0:
            break
        picks.append(best)
        gains.append(int(added[best]))
        covered |= visibility[best]
    return picks, gains


class SetCoverPlanner(PlanPlanner):
    """B_SCP over the usable candidates.

    Args:
        views: Fixed number of views (B_SCP,n); None plans until the coverage goal.
        goal: Coverage goal when `views` is None.
        max_views: View budget when planning to the goal.
        candidates: Candidate positions on the view sphere.
        resolution: Grid of the visibility renderer.

    Raises:
        ValueError: If views or max_views is < 1, or the goal is outside (0, 1].
    """

    name = "bscp"

    def __init__(self, views: int | None = None, goal: float = 0.9, max_views: int = 10,
                 candidates: int = CANDIDATE_COUNT,
                 resolution: tuple[int, int] = DEFAULT_RESOLUTION):
        super().__init__()
        if views is not None and views < 1:
            raise ValueError(f"views must be >= 1 (or None for 'until the goal'), got {views}")
        if max_views < 1:
            raise ValueError(f"max_views must be >= 1, got {max_views}")
        if not 0.0 < goal <= 1.0:
            raise ValueError(f"goal must lie in (0, 1], got {goal}")
        self.views = views
        self.goal = goal
        self.max_views = max_views
        self.candidate_count = candidates
        self.resolution = resolution
        self.stops_at_goal = views is None
        self.candidates: CandidateViews | None = None
        self.predicted_gains: list[int] = []
        self._taken: set[int] = set()

    def plan(self, episode: Episode) -> list[ViewRequest]:
        self.candidates = candidate_views(episode, self.candidate_count, self.resolution)
        count = self.views if self.views is not None else self.max_views
        goal = None if self.views is not None else self.goal
        picks, self.predicted_gains = greedy_cover(self.candidates.visibility, episode.covered,
                                                   count, goal)
        self._taken = set(picks)
        return order_requests(episode, [self.candidates.request(i) for i in picks])

    def next_view(self, episode: Episode) -> ViewRequest | None:
        view = super().next_view(episode)
        if view is not None or self.views is not None or self.candidates is None:
            return view
        # The plan is done and the goal not reached: the greedy next view on what was measured.
        best = self.candidates.next_best(episode, self._taken)
        if best is None:
            return None
        self._taken.add(best)
        return self.candidates.request(best)
