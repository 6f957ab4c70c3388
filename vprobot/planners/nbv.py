"""`nbv`: volumetric next-best view on an occupancy grid, model-free (Delmerico et al., 2018).

Like the agents it starts from the episode's initial view. After every acquisition the frame is
integrated into an occupancy grid over where an object may stand in the cell
(`vprobot.occupancy`); the candidates are the band candidates (`candidates.band_candidates`:
look-at views spread evenly over the view band at the working distance, as `uniform<k>`), each
scored by the expected information of
its rays through the grid (`DEFAULT_GAIN`). The best candidate is requested next, skipping
candidates within `EXCLUDE_DEG` of an earlier request (taken or failed) and, with the robot,
candidates the IK cannot reach from the current configuration or where the arm would hide the
view (cast against the robot's own geometry; up to `REACH_TRIES` tries per view; a failed
candidate is not tried again in the episode). The planner never reads the mesh,
the ground truth or the coverage: only the sensor's poses and points, the cell and the robot.

Stopping: in simulation the runner stops it at the coverage goal (`nbv`). Self-stopped
(`nbv@grid`) it stops when each of the latest `STOP_QUIET_VIEWS` acquisitions added less than
`STOP_NEW_SURFACE` to the occupied voxels (the surface seen so far has stopped growing: a
change rule, as MA-SCVP's; one quiet view is not enough, as a view into empty space is quiet
too),
when no candidate adds anything, or at the view budget. The expected gain of the best
candidate does not serve: unknown space the view band never measures (inside the object, under
the fixture) keeps it above 60 % of its first value after ten views that saw everything.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from vprobot.config import Config
from vprobot.episode import Episode, ViewRequest
from vprobot.kinematics import SensorTarget
from vprobot.occupancy import GAINS, VOXEL_M, EpisodeGrid, Gain
from vprobot.planners.base import Planner, register_planner
from vprobot.planners.candidates import EXCLUDE_DEG as EXCLUDE_DEG
from vprobot.planners.candidates import (
    arm_hides_view,
    band_candidates,
    offered,
    request_directions,
)
from vprobot.registry import Registry

DEFAULT_GAIN: Gain = "unknown"
REACH_TRIES = 40
"""IK attempts per view at most (best candidates first)."""
STOP_NEW_SURFACE = 0.02
"""The grid stop: the share of occupied voxels an acquisition added (chosen on the training
motors)."""
STOP_QUIET_VIEWS = 2

StopRule = Callable[["VolumetricPlanner", Episode], "str | None"]
"""Why the planner stops itself now, else None; from what the planner measured (model-free)."""
STOP_RULES: Registry[StopRule | None] = Registry("stop rule")
"""The rules of `nbv@RULE` by name: a new rule is a function registered here. `goal` (None)
leaves stopping to the runner, at the coverage goal, which only a simulation knows."""
STOP_RULES.register("goal", None)


@register_planner
class VolumetricPlanner(Planner):
    """Next-best view by information gain on an occupancy grid.

    Args:
        config: The configuration (cell, sensor, view budget).
        gain: Which gain ranks the candidates (`vprobot.occupancy.GAINS`).
        stop: A name in `STOP_RULES`: `goal` (the runner stops at the coverage goal) or `grid`
            (the planner stops itself, see the module docstring).
        voxel_m: Voxel edge of the grid.

    Raises:
        ValueError: For an unknown gain or stop rule.

    Attributes:
        episode_grid: The latest episode's grid; what each of its frames added to the
            occupied voxels is the stop rule's input.
    """

    name = "nbv"
    pattern = r"(?::(?P<gain>\w+))?(?:@(?P<stop>\w+))?"
    initial_view = True

    def __init__(self, config: Config, gain: Gain = DEFAULT_GAIN, stop: str = "goal",
                 voxel_m: float = VOXEL_M):
        if gain not in GAINS:
            raise ValueError(f"unknown gain {gain!r}; allowed: {', '.join(GAINS)}")
        if stop not in STOP_RULES:
            raise ValueError(f"unknown stop rule {stop!r} for nbv; allowed: "
                             f"{', '.join(STOP_RULES)}")
        self.config = config
        self.gain = gain
        self.stop_rule = STOP_RULES[stop]
        self.stops_at_goal = self.stop_rule is None
        self.voxel_m = voxel_m
        self._begin()

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        """`nbv`, `nbv:GAIN` (which gain ranks the views), `nbv@RULE` (a stop rule), or both."""
        return cls(config, params.get("gain", DEFAULT_GAIN), params.get("stop", "goal"))

    def reset(self, episode: Episode, rng: np.random.Generator) -> None:
        self._begin()

    def _begin(self) -> None:
        """A new episode: an all-unknown grid, nothing integrated, tried or stopped."""
        self.episode_grid = EpisodeGrid(self.config, voxel_m=self.voxel_m)
        self.stop_reason = None
        self._failed = np.zeros(len(band_candidates(self.config, self.voxel_m)), dtype=bool)

    def next_view(self, episode: Episode) -> ViewRequest | None:
        self.episode_grid.update(episode.views)
        if self.stop_rule is not None:
            self.stop_reason = self.stop_rule(self, episode)
            if self.stop_reason is not None:
                return None
        band = band_candidates(self.config, self.voxel_m)
        allowed = offered(band.directions, request_directions(episode.views, episode.center),
                          self._failed)
        scores = np.where(allowed, band.gains.score(self.episode_grid.grid, self.gain), 0.0)
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
        arm = episode.scene.arm
        result = arm.reach(target, episode.q, episode.carrier.collisions)
        if not result.reachable:
            return None
        if arm_hides_view(arm, result.q, episode.center):
            return None
        return ViewRequest(target, result.q)



@STOP_RULES.register("grid")
def grid_stop(planner: VolumetricPlanner, episode: Episode) -> str | None:
    """The grid rule: the surface seen has stopped growing, or the view budget is spent."""
    if len(episode.views) > planner.config.env.max_acquisitions:
        return "view budget"
    return surface_quiet(planner.episode_grid.added)


def surface_quiet(added: Sequence[float]) -> str | None:
    """The grid rule's test on what each informative frame added to the occupied voxels
    (`EpisodeGrid.added`): why to stop, else None; `--stop grid` applies it to any planner."""
    recent = added[-STOP_QUIET_VIEWS:]
    if len(added) > STOP_QUIET_VIEWS and max(recent) < STOP_NEW_SURFACE:
        return (f"grid: the latest {STOP_QUIET_VIEWS} views each added less than "
                f"{STOP_NEW_SURFACE:.0%} to the seen surface")
    return None
