"""`nbv`: volumetric next-best view on an occupancy grid, model-free (Delmerico et al., 2018).

Like the agents it starts from the episode's initial view. After every acquisition the frame is
integrated into an occupancy grid over where an object may stand in the cell
(`vprobot.coverage.occupancy`); the candidates are the band candidates (`views.band_candidates`:
look-at views spread evenly over the view band at the working distance, as `uniform<k>`), each
scored by the expected information of its rays through the grid (`DEFAULT_GAIN`) as its sensor
would measure it (`vprobot.coverage.view_gains.ViewGains.scores`: under structured light only what
the projector lights within both incidence limits; with the ideal sensor what the camera sees).
Under structured light it adds `REVISIT_WEIGHT` times the revisit gain (`ViewGains.revisits`: the
occupied voxels it would measure from a direction none of their points was measured from), so
that once the unknown it can measure runs out it looks again at edges, fillets and bores from
new sides instead of running to the budget.
`nbv_camera` scores by what the camera sees whatever the sensor (`vprobot.planners.nbv_camera`),
as `nbv` did before issue 45. The best candidate is requested next, skipping
candidates within `EXCLUDE_DEG` of an earlier request (taken or failed) and, with the robot,
candidates the IK cannot reach from the current configuration or where the arm would hide the
view (cast against the robot's own geometry; up to `REACH_TRIES` tries per view; a failed
candidate is not tried again in the episode). The planner never reads the mesh,
the ground truth or the coverage: only the sensor's poses and points, the cell and the robot.

Stopping: in simulation the runner stops it at the coverage goal (`nbv`). Named `nbv@RULE`
(`nbv@grid`, `nbv@views:5`) it stops itself by the stop rule `RULE` of `STOPS`
(`vprobot.stopping.rules`), asked before every view, when no candidate adds anything, or at the
view budget; `nbv@goal` is `nbv`, left to the runner. The expected gain of the best candidate
does not serve as a stop: unknown space the view band never measures (inside the object, under
the fixture) keeps it above 60 % of its first value after ten views that saw everything.
"""

from __future__ import annotations

from typing import ClassVar, cast

import numpy as np

from vprobot.config import Config
from vprobot.coverage.occupancy import GAINS, VOXEL_M, Gain, GridSettings
from vprobot.episode import Episode, ViewRequest
from vprobot.episode.views import EXCLUDE_DEG as EXCLUDE_DEG
from vprobot.episode.views import band_candidates, offered, request_directions
from vprobot.kinematics import SensorTarget
from vprobot.planners.base import Planner, register_planner
from vprobot.planners.candidates import arm_hides_view
from vprobot.planners.initial_view import InitialViewPlanner
from vprobot.planners.self_stopping import SelfStopping, stop_subject
from vprobot.sensing.structured_light import StructuredLight
from vprobot.stopping.rules import StopRule, make_stop_rule

DEFAULT_GAIN: Gain = "unknown"
REVISIT_WEIGHT = 10.0
"""Under structured light, what a revisited occupied voxel weighs against the gain's samples
(`ViewGains.revisits`): chosen on `validation-v2` in the realistic cell among 1, 3, 10 and 30."""
REACH_TRIES = 40
"""IK attempts per view at most (best candidates first)."""


@register_planner
class VolumetricPlanner(InitialViewPlanner, SelfStopping):
    """Next-best view by information gain on an occupancy grid.

    Args:
        config: The configuration (cell, sensor, view budget).
        gain: Which gain ranks the candidates (`vprobot.coverage.occupancy.GAINS`).
        stop: A stop rule of `STOPS` (`vprobot.stopping.rules`) the planner stops itself by
            (`grid`, `views:5`, ...); `goal`: the runner stops it at the coverage goal.
        voxel_m: Voxel edge of the grid.

    Raises:
        ValueError: For an unknown gain, an unknown stop rule or one that does not apply to
            the planner (`agent`).

    Attributes:
        settings: The settings of the episode's grid it reads (`Episode.occupancy`).
        stop_rule: The rule it stops itself by; None under `goal`.
        revisits: Whether it adds the revisit gain (`REVISIT_WEIGHT`): it scores what the sensor
            measures, and the sensor is a structured-light one.
    """

    name = "nbv"
    pattern = r"(?::(?P<gain>\w+))?(?:@(?P<stop>.+))?"
    evaluated: ClassVar[tuple[str, ...]] = ("nbv", "nbv@grid")
    sensed: ClassVar[bool] = True
    """Whether candidates score by what the sensor measures (else by what the camera sees)."""

    def __init__(self, config: Config, gain: Gain = DEFAULT_GAIN, stop: str = "goal",
                 voxel_m: float = VOXEL_M):
        if gain not in GAINS:
            raise ValueError(f"unknown gain {gain!r}; allowed: {', '.join(GAINS)}")
        self.config = config
        self.gain = gain
        self.stop_rule: StopRule | None = None
        self.stops_at_goal = stop == "goal"
        if not self.stops_at_goal:
            try:
                self.stop_rule = make_stop_rule(stop, config)
                self.stop_rule.bind(stop_subject(self))
            except ValueError as error:
                raise ValueError(f"nbv@{stop}: {error}") from None
        self.voxel_m = voxel_m
        self.settings = GridSettings.of(config, voxel_m=voxel_m)
        self.revisits = self.sensed and isinstance(config.sensor.sensing_model, StructuredLight)
        self._begin()

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        """`nbv`, `nbv:GAIN` (which gain ranks the views), `nbv@RULE` (the stop rule it stops
        itself by), or both."""
        # __init__ rejects a name that is not a gain.
        gain = cast(Gain, params.get("gain", DEFAULT_GAIN))
        return cls(config, gain, params.get("stop", "goal"))

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._begin()

    def _begin(self) -> None:
        """A new episode: nothing tried or stopped."""
        self.stop_reason = None
        if self.stop_rule is not None:
            self.stop_rule.reset()
        self._failed = np.zeros(len(band_candidates(self.config, self.voxel_m)), dtype=bool)

    def next_view(self, episode: Episode) -> ViewRequest | None:
        if self.stop_rule is not None:
            # Self-stopped, the runner leaves the view budget to the planner.
            self.stop_reason = ("view budget"
                                if len(episode.views) > self.config.env.max_acquisitions
                                else self.stop_rule.check(episode))
            if self.stop_reason is not None:
                return None
        band = band_candidates(self.config, self.voxel_m)
        allowed = offered(band.directions, request_directions(episode.views, episode.center),
                          self._failed)
        grid = episode.occupancy(self.settings).grid
        column = GAINS.index(self.gain)
        if not self.sensed:
            gains = band.gains.score(grid, self.gain)
        elif self.revisits:
            sensed = band.gains.revisits(grid)
            gains = sensed.scores[:, column] + REVISIT_WEIGHT * sensed.revisit
        else:
            gains = band.gains.scores(grid)[:, column]
        scores = np.where(allowed, gains, 0.0)
        for index in np.argsort(-scores, kind="stable")[:REACH_TRIES]:
            if scores[index] <= 0.0:
                break
            request = self._reached(episode, band.targets[index])
            if request is not None:
                return request
            self._failed[index] = True
        self.stop_reason = "no reachable candidate adds anything"
        return None

    @staticmethod
    def _reached(episode: Episode, target: SensorTarget) -> ViewRequest | None:
        """The request of a target the carrier can take, else None: with the robot, an IK
        solution from the current configuration whose arm does not hide the view's centre."""
        if not episode.uses_robot:
            return ViewRequest(target)
        result = episode.robot.reach(target, episode.q)
        if not result.reachable:
            return None
        if arm_hides_view(episode.scene.arm, result.q, episode.center):
            return None
        return ViewRequest(target, result.q)

