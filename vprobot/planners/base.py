"""The planner interface: a next view from the current state of an episode, or a whole plan.

A `Planner` is asked for one `ViewRequest` at a time for an `Episode` (robot in the loop or
free-flying sensor, `vprobot.episode`) until it returns None or the runner stops it (coverage
goal, view budget); planners that compute a whole plan up front (`PlanPlanner`) hand it out
view by view.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from vprobot.episode import Episode, ViewRequest

if TYPE_CHECKING:
    # candidates builds on this module's interface.
    from vprobot.planners.candidates import CandidateViews


class Planner(abc.ABC):
    """Chooses the views of an episode.

    Attributes:
        name: Registry name (`random1`, `random2`, `hrec`, `bscp`, `oracle`, `uniform`, `nbv`).
        initial_view: Whether the episode starts with the environment's fixed initial view, as
            the next-best-view agents of the paper do (whole-plan baselines do not).
        stops_at_goal: Whether the runner stops at the coverage goal (a fixed plan runs out).
        candidates: The candidate views a model-based planner chose from in its last episode.
        stop_reason: Why the planner stopped itself in its last episode (None when it did not:
            the runner stopped it, or a fixed plan ran out).
    """

    name: ClassVar[str]
    initial_view: ClassVar[bool] = False
    stops_at_goal: bool = True
    candidates: CandidateViews | None = None
    stop_reason: str | None = None

    @abc.abstractmethod
    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        """Prepare for a new episode (before its first view); `rng` drives any randomness."""

    @abc.abstractmethod
    def next_view(self, episode: Episode) -> ViewRequest | None:
        """The next view given the episode so far; None when the planner has nothing to add."""


class PlanPlanner(Planner):
    """A planner that computes a whole plan at reset and hands it out in order."""

    def __init__(self) -> None:
        self._queue: list[ViewRequest] = []

    @abc.abstractmethod
    def plan(self, episode: Episode) -> list[ViewRequest]:
        """The whole plan for the episode, in execution order."""

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._queue = list(self.plan(episode))

    def next_view(self, episode: Episode) -> ViewRequest | None:
        return self._queue.pop(0) if self._queue else None
