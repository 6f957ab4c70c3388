"""Observations of the inspection environment (docs/states-actions-rewards.md#states).

Point coordinates are in the object-centred frame: origin at the object's centre, axes parallel
to the world's (z up), so the episode's random rotation and tilt show in the state. They are
divided by a fixed scale from the config (`env.state_scale_m`), not by a per-object min-max.
The `s_grid` state is built in `vprobot.env.grid_state`. The env and the agent planner each own
an `Observer`, so that an agent plans from the very state it was trained on.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from vprobot.config import Config, EnvConfig
from vprobot.env.grid_state import GridState, candidate_count, grid_features, grid_spaces
from vprobot.episode.records import ViewRequest
from vprobot.geometry.poses import Pose
from vprobot.robots import load_robot

if TYPE_CHECKING:
    from vprobot.env.actions import ActionMapping
    from vprobot.episode import Episode

POINT_BOUND = 4.0
"""Declared bound of the scaled point coordinates (points beyond are clipped)."""
POSITION_BOUND = 8.0
"""Declared bound of the scaled sensor position in the robot state."""


def robot_state_size(dof: int) -> int:
    """Sensor position, the sensor's x and z axes, and the `dof` joint angles / (2 pi)."""
    return 3 + 6 + dof


def points_space(config: EnvConfig) -> spaces.Box:
    """`s_cov`: (N, 3) acquired cloud; `s_bin`: (N, 4) GT cloud with a covered column."""
    columns = 3 if config.state == "s_cov" else 4
    low = np.full((config.state_points, columns), -POINT_BOUND, dtype=np.float32)
    high = np.full((config.state_points, columns), POINT_BOUND, dtype=np.float32)
    if columns == 4:
        low[:, 3], high[:, 3] = 0.0, 1.0
    return spaces.Box(low, high, dtype=np.float32)


def observation_space(config: Config) -> spaces.Space:
    """A Box of points, or a Dict of points and robot state when `env.robot_state` is set (sized
    by the joints of the configured robot); for `s_grid` a Dict of candidates and mask (and the
    robot state)."""
    if config.env.state == "s_grid":
        entries: dict[str, spaces.Space] = dict(grid_spaces(candidate_count(),
                                                               grid_features(config)))
    elif not config.env.robot_state:
        return points_space(config.env)
    else:
        entries = {"points": points_space(config.env)}
    if config.env.robot_state:
        size = robot_state_size(load_robot(config.cell.robot).dof)
        entries["robot"] = spaces.Box(-POSITION_BOUND, POSITION_BOUND, (size,), dtype=np.float32)
    return spaces.Dict(entries)


def resample(points: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Exactly `count` points: a random subset, or all points plus random duplicates.

    An empty cloud becomes `count` points at the origin (the object's centre).
    """
    if len(points) == 0:
        return np.zeros((count, points.shape[1]))
    if len(points) >= count:
        return points[rng.choice(len(points), count, replace=False)]
    extra = rng.choice(len(points), count - len(points), replace=True)
    return np.concatenate([points, points[extra]])


def gt_rows(gt_count: int, count: int) -> np.ndarray:
    """The GT points an `s_bin` state of `count` rows shows: the first `count` (the GT is stored
    in farthest-point order, so any prefix is spread evenly), repeated cyclically beyond it."""
    return np.arange(count) % gt_count


def scaled(points_object: np.ndarray, config: EnvConfig) -> np.ndarray:
    """Object-frame coordinates divided by the state scale, clipped to the declared bounds."""
    return np.clip(points_object / config.state_scale_m, -POINT_BOUND, POINT_BOUND)


def robot_state(sensor_pose: Pose, object_center: np.ndarray, joints: np.ndarray,
                config: EnvConfig) -> np.ndarray:
    """Sensor position (object-centred, scaled), its x and z axes, joints / (2 pi)."""
    position = (sensor_pose.position - object_center) / config.state_scale_m
    return np.concatenate([
        np.clip(position, -POSITION_BOUND, POSITION_BOUND),
        sensor_pose.rotation[:, 0],
        sensor_pose.rotation[:, 2],
        joints / (2.0 * np.pi),
    ]).astype(np.float32)


class Observer:
    """Builds the state of episodes: what the agent is given
    (docs/states-actions-rewards.md#states).

    With `s_cov` the points are the accumulated acquired cloud only, posed in the world-aligned
    object frame (the model-free premise: a real cell measures these points in the world and
    knows where the fixture holds the object); `s_bin` shows the ground truth and its covered
    flags, so it needs the object model; `s_grid` (model-free) reads the episode's occupancy
    grid and keeps the episode's reachability screening, so `reset` must start every episode.

    Args:
        config: The configuration (`env` says which state).
        resolution: The resolution of the episodes' frames; None for the configured sensor's.
    """

    def __init__(self, config: Config, resolution: tuple[int, int] | None = None):
        self.config = config.env
        self.grid_state = (GridState(config, resolution) if config.env.state == "s_grid"
                           else None)

    def reset(self) -> None:
        """A new episode."""
        if self.grid_state is not None:
            self.grid_state.reset()

    def request(self, mapping: ActionMapping, action: np.ndarray | int, center: np.ndarray,
                roll_free: bool) -> ViewRequest:
        """The view request of an action. With `s_grid` an `A_view` request carries the
        configuration the screening found for its candidate: the robot drives there when the
        path is free (as B_SCP executes its candidates), else reaches it by IK from where it
        is, as any request."""
        target = mapping.target(action, center, roll_free)
        joints = (None if self.grid_state is None
                  else self.grid_state.joints_of(mapping.candidate(action)))
        return ViewRequest(target, joints)

    def observe(self, episode: Episode, rng: np.random.Generator) -> Any:
        """The state of the episode so far (`rng` resamples the point states)."""
        config = self.config
        if self.grid_state is not None:
            state: dict[str, np.ndarray] = self.grid_state.observe(episode)
        else:
            points = self._points(episode, rng)
            if not config.robot_state:
                return points
            state = {"points": points}
        if config.robot_state:
            state["robot"] = robot_state(episode.sensor_pose(), episode.center, episode.q, config)
        return state

    def _points(self, episode: Episode, rng: np.random.Generator) -> np.ndarray:
        config = self.config
        rotation = episode.object_pose.rotation
        if config.state == "s_cov":
            cloud = episode.tracker.accumulated_cloud @ rotation.T
            points = scaled(resample(cloud, config.state_points, rng), config)
        else:
            rows = gt_rows(len(episode.tracker.gt_points), config.state_points)
            gt = episode.tracker.gt_points[rows] @ rotation.T
            points = np.column_stack([scaled(gt, config), episode.tracker.covered[rows]])
        return points.astype(np.float32)
