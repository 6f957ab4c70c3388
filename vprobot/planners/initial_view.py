"""Planners whose episodes start from the environment's initial view."""

from __future__ import annotations

from vprobot.planners.base import Planner


class InitialViewPlanner(Planner):
    """A planner whose episodes start with the environment's fixed initial view (the spec's,
    `EpisodeSpec.initial_requests`), as the next-best-view agents of the paper do: the runner
    takes it before the first request. Other planners (the whole-plan baselines) start with
    their own first view."""
