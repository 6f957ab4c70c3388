"""What an exact planner proves of its plan."""

from __future__ import annotations

import dataclasses

from vprobot.planners.base import Planner


@dataclasses.dataclass(frozen=True)
class Proof:
    """What an exact planner proved of its last plan (`optimum`).

    Attributes:
        proven: Whether the plan is proven optimal on the measured rows of its views.
        bound: The last solve's proven bound: the fewest views that reach the goal, or the most
            GT points a fixed number of views adds (`optimum<N>`, or a goal out of reach).
        gap_views: Views above the proven fewest (0 when proven; None without that bound).
    """

    proven: bool
    bound: int | None
    gap_views: int | None


class ExactPlanner(Planner):
    """A planner that proves what it plans: the runner reports the proof with the episode
    (`EpisodeResult.proof`) and the evaluation in its `proven` and `gap_views` columns.

    Attributes:
        proof: What it proved of its last episode's plan; None before its first plan, and
            where a wall-clock safety net cut its solves short.
    """

    proof: Proof | None = None
