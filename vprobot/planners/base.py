"""The planner interface: a next view from the current state of an episode, or a whole plan.

An `Episode` is one inspection of a motor in a fixed object pose, with the robot in the loop
(`vprobot.planners.episode.RobotEpisode`) or with a free-flying sensor as in the paper
(`vprobot.planners.free_flying.FreeFlyingEpisode`). A `Planner` is asked for one `ViewRequest`
at a time until it returns None or the runner stops it (coverage goal, view budget); planners
that compute a whole plan up front (`PlanPlanner`) hand it out view by view.
"""

from __future__ import annotations

import abc
import dataclasses
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from vprobot.episode import EpisodeRecord, ViewRecord
from vprobot.geometry import Pose
from vprobot.inspection import MotorScene
from vprobot.kinematics import SensorTarget

if TYPE_CHECKING:
    # candidates builds on this module's interface.
    from vprobot.planners.candidates import CandidateViews


@dataclasses.dataclass(frozen=True)
class ViewRequest:
    """A view a planner asks for.

    Attributes:
        target: The requested sensor pose in the world.
        joints: A robot configuration known to reach the target (a screened candidate); the
            robot drives there directly when the joint-space path is free, else the IK is asked.
    """

    target: SensorTarget
    joints: np.ndarray | None = None


class Episode(abc.ABC):
    """One inspection of a motor scene in one object pose.

    Attributes:
        scene: The motor scene.
        object_pose: Pose of the object's mesh frame in the world.
        uses_robot: Whether views are reached by the robot (else the sensor flies freely).
    """

    scene: MotorScene
    object_pose: Pose
    uses_robot: ClassVar[bool]

    @property
    def center(self) -> np.ndarray:
        """The object's centre in the world."""
        return self.object_pose.position

    @property
    @abc.abstractmethod
    def q(self) -> np.ndarray:
        """The robot's current configuration (the start configuration when it is not used)."""

    @property
    @abc.abstractmethod
    def covered(self) -> np.ndarray:
        """Which ground-truth points are covered so far (a copy)."""

    @property
    def coverage(self) -> float:
        return float(self.covered.mean())

    @property
    @abc.abstractmethod
    def views(self) -> list[ViewRecord]:
        """The views requested so far, in order."""

    @abc.abstractmethod
    def preview(self, view: ViewRequest) -> np.ndarray:
        """Which GT points the view alone would cover, simulated without executing it.

        Raises:
            ValueError: If the view cannot be simulated (with the robot: it needs joints).
        """

    @abc.abstractmethod
    def execute(self, view: ViewRequest) -> ViewRecord:
        """Move to the view if possible and acquire there; never acquires from an unreached pose."""

    @abc.abstractmethod
    def record(self) -> EpisodeRecord:
        """The episode so far, for rendering and export."""


class Planner(abc.ABC):
    """Chooses the views of an episode.

    Attributes:
        name: Registry name (`random1`, `random2`, `hrec`, `bscp`, `oracle`).
        initial_view: Whether the episode starts with the environment's fixed initial view, as
            the next-best-view agents of the paper do (whole-plan baselines do not).
        stops_at_goal: Whether the runner stops at the coverage goal (a fixed plan runs out).
        candidates: The candidate views a model-based planner chose from in its last episode.
    """

    name: ClassVar[str]
    initial_view: ClassVar[bool] = False
    stops_at_goal: bool = True
    candidates: CandidateViews | None = None

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
