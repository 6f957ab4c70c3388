"""`goal`: the simulator's stop at the coverage goal (the default), which only a simulation can
apply: a real cell does not know the coverage."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from vprobot.config import Config
from vprobot.stopping.rules.base import StopRule, StopSubject, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode


@register_stop
class GoalStop(StopRule):
    """Stops a planner that stops at the goal (`StopSubject.stops_at_goal`) once the coverage
    reaches it; a planner that stops itself (a fixed plan, `nbv@grid`, an agent with a stop
    action) keeps doing so, as before there were stop rules."""

    name = "goal"
    description = "the simulator's stop at the coverage goal"
    keeps_learned_stop = True

    def __init__(self, goal: float):
        self.goal = goal

    @classmethod
    def build(cls, config: Config, estimator: str | Path | None = None,
              **options: Any) -> StopRule:
        return cls(config.env.coverage_goal)

    def governs(self, planner: StopSubject) -> bool:
        return planner.stops_at_goal

    def check(self, episode: Episode) -> str | None:
        return "goal reached" if episode.coverage >= self.goal else None
