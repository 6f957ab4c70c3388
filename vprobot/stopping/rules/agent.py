"""`agent`: the learned stop, an agent trained with a stop action deciding itself."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vprobot.stopping.rules.base import StopRule, StopSubject, register_stop

if TYPE_CHECKING:
    from vprobot.episode import Episode


@register_stop
class AgentStop(StopRule):
    """Leaves stopping to the agent's stop action; the runner still stops at the view budget."""

    name = "agent"
    description = "the agent's learned stop action"
    keeps_learned_stop = True

    def applies_to(self, planner: StopSubject) -> bool:
        return planner.decides_stop

    def bind(self, planner: StopSubject) -> None:
        if not self.applies_to(planner):
            raise ValueError(f"stop rule 'agent' needs an agent planner whose action has a stop "
                             f"(trained with env.stop_action, e.g. "
                             f"agent:cpu-stop); planner {planner.name!r} "
                             f"has none")

    def check(self, episode: Episode) -> str | None:
        return None
