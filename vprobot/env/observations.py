"""Observations of the inspection environment (docs/states-actions-rewards.md#states).

Point coordinates are in the object-centred frame: origin at the object's centre, axes parallel
to the world's (z up), so the episode's random rotation and tilt show in the state. They are
divided by a fixed scale from the config (`env.state_scale_m`), not by a per-object min-max.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from vprobot.config import Config, EnvConfig
from vprobot.geometry import Pose
from vprobot.robots import load_robot

if TYPE_CHECKING:
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
    by the joints of the configured robot)."""
    points = points_space(config.env)
    if not config.env.robot_state:
        return points
    size = robot_state_size(load_robot(config.cell.robot).dof)
    robot = spaces.Box(-POSITION_BOUND, POSITION_BOUND, (size,), dtype=np.float32)
    return spaces.Dict({"points": points, "robot": robot})


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


def observe(episode: Episode, config: EnvConfig, rng: np.random.Generator) -> Any:
    """The state of an episode (docs/states-actions-rewards.md#states): what the agent is given.

    With `s_cov` the points are the accumulated acquired cloud only, posed in the world-aligned
    object frame (the model-free premise: a real cell measures these points in the world and
    knows where the fixture holds the object); `s_bin` shows the ground truth and its covered
    flags, so it needs the object model.
    """
    rotation = episode.object_pose.rotation
    if config.state == "s_cov":
        cloud = episode.tracker.accumulated_cloud @ rotation.T
        points = scaled(resample(cloud, config.state_points, rng), config)
    else:
        rows = gt_rows(len(episode.tracker.gt_points), config.state_points)
        gt = episode.tracker.gt_points[rows] @ rotation.T
        points = np.column_stack([scaled(gt, config), episode.tracker.covered[rows]])
    points = points.astype(np.float32)
    if not config.robot_state:
        return points
    state = robot_state(episode.sensor_pose(), episode.center, episode.q, config)
    return {"points": points, "robot": state}
