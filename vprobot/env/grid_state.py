"""`s_grid`: the state of an `A_view` agent, one row of features per band candidate.

The state is built from the episode's occupancy grid (`Episode.occupancy`: each frame integrated
once, for every reader of a grid of the same settings) and from where views were requested, as
`nbv` plans: it reads the views' requested poses, sensor poses, points, pixels and blocked
pixels and the object's centre, never the mesh, the ground truth or the coverage. Every row holds
the same features (`FEATURES`; under structured light `SENSED_FEATURES` after them), so a
network can score each candidate with one shared function of its row; the episode-wide context is
repeated on every row. With the robot, the candidates'
reachability is screened once per episode (`screen_reachability`, from the configuration the
episode starts in): a row says whether the candidate is reachable and how far the joints move to
it. `mask` marks the candidates that may be requested (`offered`: not within `EXCLUDE_DEG` of an
earlier request, taken or failed, and not failed; and reachable); should that leave none, every
candidate that did not fail is offered again, so an action always exists.

A request or a sensor pose belongs to a candidate when its direction from the centre lies within
`MATCH_DEG` of the candidate's (the robot reaches a target to about 0.1 degrees).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from gymnasium import spaces

from vprobot.config import Config
from vprobot.coverage.occupancy import GAINS, VOXEL_M, GridSettings
from vprobot.coverage.view_gains import measurable_share
from vprobot.env.rewards import step_limit
from vprobot.episode.views import (
    band_candidates,
    band_directions,
    offered,
    request_directions,
    screen_band,
)
from vprobot.sensing.structured_light import StructuredLight

if TYPE_CHECKING:
    from vprobot.episode import Episode

FEATURES: tuple[str, ...] = (
    *(f"gain_{gain}" for gain in GAINS),
    *(f"gain_{gain}_relative" for gain in GAINS),
    "direction_x", "direction_y", "direction_z",
    "closest_request_cos",
    "current_cos",
    "current",
    "failed",
    "reachable",
    "joint_move",
    "requests_used",
    "occupied_share", "free_share", "unknown_share",
)
"""The columns of `candidates`, in order (see `InspectEnv`'s docstring for what each holds)."""
SENSED_FEATURES: tuple[str, ...] = ("gain_revisit", "gain_revisit_relative", "measurable_left")
"""The columns that follow `FEATURES` under structured light, where `nbv` adds the revisit gain
(`ViewGains.revisits`): that gain per ray, relative to the best offered, and the share of the
surface known so far that the reachable candidates would still measure (`measurable_share`, the
same on every row). With the ideal sensor the state keeps `FEATURES` alone, as the paper cell's
agent was trained on."""
VERSION = 3
"""Raised when what a column holds changes (3: `SENSED_FEATURES` under structured light; 2: the
gains are what the candidate's sensor would measure, issue 45; 1: what the camera sees): states
stored under another version, a teacher's, are not this state's."""
MATCH_DEG = 1.0
"""A direction this close to a candidate's is that candidate's."""
_SIGNED = ("direction_x", "direction_y", "direction_z", "closest_request_cos", "current_cos")
"""The columns in [-1, 1]; the others lie in [0, 1]."""


def grid_features(config: Config) -> tuple[str, ...]:
    """The columns of `candidates` for the cell's sensing model."""
    sensed = isinstance(config.sensor.sensing_model, StructuredLight)
    return (*FEATURES, *SENSED_FEATURES) if sensed else FEATURES


def grid_spaces(count: int, features: tuple[str, ...]) -> dict[str, spaces.Box]:
    """The `candidates` (count, features) and `mask` (count,) entries of the state."""
    low = np.array([-1.0 if name in _SIGNED else 0.0 for name in features], dtype=np.float32)
    return {"candidates": spaces.Box(np.tile(low, (count, 1)),
                                     np.ones((count, len(features)), dtype=np.float32),
                                     dtype=np.float32),
            "mask": spaces.Box(0.0, 1.0, (count,), dtype=np.float32)}


def candidate_count() -> int:
    """Rows of the state: the band candidates, one per `A_view` action."""
    return len(band_directions())


class GridState:
    """Builds the `s_grid` state of an episode from the episode's grid of its settings.

    Args:
        config: The cell, the sensor and the env (its view budget).
        resolution: The resolution of the episode's frames; None for the configured sensor's.
    """

    def __init__(self, config: Config, resolution: tuple[int, int] | None = None):
        self.band = band_candidates(config, VOXEL_M)
        self.settings = GridSettings.of(config, resolution)
        self.step_limit = step_limit(config.env)
        self._match = np.cos(np.deg2rad(MATCH_DEG))
        self.features = grid_features(config)
        self._low = grid_spaces(len(self.band), self.features)["candidates"].low[0]
        self._screening: tuple[np.ndarray, tuple[str | None, ...]] | None = None

    def reset(self) -> None:
        """A new episode: reachability not screened yet."""
        self._screening = None

    def screening(self, episode: Episode) -> tuple[np.ndarray, tuple[str | None, ...]]:
        """A configuration (count, dof) reaching each candidate, NaN rows for those the robot
        does not reach, and the IK's reason for each of those (none without the robot: a free
        sensor takes every view, and the array has no columns). Screened once per episode from
        where it starts (the object's placement decides what collides), as B_SCP screens its
        candidates; nbv tries the IK per request instead."""
        if self._screening is None:
            self._screening = screen_band(episode, self.band)
        return self._screening

    def joints_of(self, candidate: int) -> np.ndarray | None:
        """The configuration the screening found for a candidate; None where it found none,
        free-flying, or before the episode's first state."""
        if self._screening is None or self._screening[0].shape[1] == 0:
            return None
        joints = self._screening[0][candidate]
        return None if np.isnan(joints).any() else joints.copy()

    def observe(self, episode: Episode) -> dict[str, np.ndarray]:
        """The `candidates` and `mask` entries for the episode's views so far."""
        views = episode.views
        episode_grid = episode.occupancy(self.settings)
        grid = episode_grid.grid
        directions = self.band.directions
        requested = request_directions(views, episode.center)
        cosines = directions @ requested.T
        unreached = np.array([not view.reachable for view in views], dtype=bool)
        failed = (cosines[:, unreached] >= self._match).any(axis=1)
        joints, _ = self.screening(episode)
        reachable = ~np.isnan(joints).any(axis=1)
        mask = offered(directions, requested, failed) & reachable
        if not mask.any():
            mask = ~failed
        gains = self.band.gains
        # What each candidate's sensor would measure (under structured light, what its
        # projector lights within the incidence limits; else what the camera sees).
        sensed = len(self.features) > len(FEATURES)
        if sensed:
            scores, revisit, measurable = gains.revisits(grid, reachable & ~failed)
        else:
            scores = gains.scores(grid)
        scores = scores / (gains.rays * gains.ray_bound)
        current_cos = directions @ self._sensor_direction(episode)
        counts = episode_grid.counts()
        context = [min((len(views) - 1) / self.step_limit, 1.0),
                   *(counts[kind] / grid.state.size for kind in ("occupied", "free", "unknown"))]
        rows = np.column_stack([
            scores,
            _relative(scores, mask),
            directions,
            cosines.max(axis=1, initial=-1.0),
            current_cos,
            current_cos >= self._match,
            failed,
            reachable,
            self._joint_moves(joints, episode),
            np.tile(context, (len(directions), 1)),
        ])
        if sensed:
            revisit = revisit[:, None] / gains.rays
            rows = np.column_stack([
                rows, revisit, _relative(revisit, mask),
                np.full(len(rows), measurable_share(measurable, counts["occupied"]))])
        # Clipped to the declared bounds: an unoffered candidate may gain more than the best
        # offered one, and float32 may round a cosine past 1.
        return {"candidates": np.clip(rows, self._low, 1.0).astype(np.float32),
                "mask": mask.astype(np.float32)}

    @staticmethod
    def _joint_moves(joints: np.ndarray, episode: Episode) -> np.ndarray:
        """The largest joint move from where the robot is to each candidate's screened
        configuration, in half turns (1 where unreachable, 0 free-flying)."""
        if joints.shape[1] == 0:
            return np.zeros(len(joints))
        return np.nan_to_num(np.abs(joints - episode.q).max(axis=1) / np.pi, nan=1.0)

    @staticmethod
    def _sensor_direction(episode: Episode) -> np.ndarray:
        """Unit direction from the centre to where the sensor is: the latest acquisition's pose
        (a request the carrier did not take leaves the sensor there)."""
        acquired = [view.sensor_pose for view in episode.views if view.sensor_pose is not None]
        if not acquired:
            return np.zeros(3)
        offset = acquired[-1].position - episode.center
        return offset / np.linalg.norm(offset)


def _relative(scores: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Scores (count, columns) over the largest of an offered candidate, column by column (0
    where that is 0)."""
    best = scores[mask].max(axis=0, initial=0.0)
    return np.divide(scores, best, out=np.zeros_like(scores), where=best > 0.0)
