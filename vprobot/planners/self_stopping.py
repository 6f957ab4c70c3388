"""Planners that may end their episodes themselves, and what a stop rule sees of a planner.

The runner stops a planner at the coverage goal or the view budget under `--stop goal`, unless
the planner is a `SelfStopping` one that does not stop at the goal: a fixed plan that runs out
(`hrec`, `uniform<k>`, `bscp5`), one that stops by a rule of its own (`nbv@grid`), an agent with
a learned stop (`LearnedStop`). Stop rules see none of this but the `StopSubject` that
`stop_subject` reads off a planner.
"""

from __future__ import annotations

from vprobot.planners.base import Planner
from vprobot.stopping.rules import StopSubject


class SelfStopping(Planner):
    """A planner that may end its episodes itself, by running out of views or for a reason of
    its own.

    Attributes:
        stops_at_goal: Whether the runner still stops it at the coverage goal (`bscp` without a
            view count); by default it runs to its own end.
        stop_reason: Why it stopped itself in its last episode, set before `next_view` returns
            None; None when it did not (the runner stopped it, or a fixed plan ran out). Its
            `reset` clears it.
    """

    stops_at_goal: bool = False
    stop_reason: str | None = None


class LearnedStop(SelfStopping):
    """A planner that decides itself when to stop (an agent trained with a stop action).

    Attributes:
        decides_stop: Whether its stop is in use: a stop rule other than `goal` and `agent`
            takes over, and the runner turns it off (`StopRule.keeps_learned_stop`).
    """

    decides_stop: bool = True


def stop_subject(planner: Planner) -> StopSubject:
    """What a stop rule sees of `planner` as it is now: a planner that is not `SelfStopping`
    stops at the goal, and one without a `LearnedStop` does not decide its stop."""
    return StopSubject(planner.name,
                       planner.stops_at_goal if isinstance(planner, SelfStopping) else True,
                       isinstance(planner, LearnedStop) and planner.decides_stop)
