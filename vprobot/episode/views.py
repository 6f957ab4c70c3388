"""Candidate views that need no model of the object, for every layer above the episode: look-at
targets around the object's centre, their reachability from the episode's start, and the
model-free band of `nbv`, the environment's `A_view` action and the coverage estimate.

Look-at targets (`look_at_targets`) sit at a distance from the object's centre along unit
directions, looking at it. With the robot, every one is reached by the IK for the episode's
object pose (`screen_reachability`): the targets are visited breadth-first over their
neighbourhood graph, each IK warm-started from an already solved neighbour, so a reachable
target converges in a few iterations and neighbours share an arm branch (short joint moves
between them). The screening uses at most `SCREEN_RESTARTS` restarts: a target it misses is
merely not offered.

The band candidates (`band_candidates`) know nothing of the object: `BAND_COUNT` look-at views
over the part of the sphere the ground truth was defined from (`ground_truth.MAX_POLAR_DEG`) at
the working distance around the cell's object centre, with their rays through the cell's
occupancy grid. `offered` says which of them may still be requested: none within `EXCLUDE_DEG`
of an earlier request and none that failed.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from vprobot.config import Config
from vprobot.config.sensor import SensorModel
from vprobot.coverage.ground_truth import MAX_POLAR_DEG
from vprobot.coverage.occupancy import OccupancyGrid
from vprobot.coverage.view_gains import ViewGains
from vprobot.files.progress import stage
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.kinematics.collision import CollisionChecker

if TYPE_CHECKING:
    from vprobot.episode import Episode, ViewRecord

SCREEN_RESTARTS = 1
"""IK restarts (home) of the screening: 8 find the same reachable candidates (781 of 900 on the
default motor, one more on some) at twice the time, none misses about 3 %."""
_NEIGHBOURS = 8
BAND_COUNT = 128
"""Band candidates (model-free): about 15 degrees apart."""
EXCLUDE_DEG = 10.0
"""Band candidates this close to an earlier request are not offered again."""


def look_at_targets(center: np.ndarray, distance: float,
                    directions: np.ndarray) -> tuple[SensorTarget, ...]:
    """Targets `distance` from `center` along each unit direction (n, 3), looking at it."""
    center = np.asarray(center, dtype=float)
    return tuple(SensorTarget.look_at(center + distance * d, center) for d in directions)


def nearest_directions(directions: np.ndarray) -> np.ndarray:
    """Each unit direction's nearest others (count, up to 8) as indices, nearest first: the
    neighbourhood the screening and `uniform`'s spreading walk."""
    count = len(directions)
    _, found = cKDTree(directions).query(directions, k=min(_NEIGHBOURS + 1, count))
    return np.asarray(found).reshape(count, -1)[:, 1:]


def screen_reachability(arm: RobotArm, collisions: CollisionChecker, start_q: np.ndarray,
                        directions: np.ndarray, targets: Sequence[SensorTarget]
                        ) -> tuple[np.ndarray, tuple[str | None, ...]]:
    """IK of every candidate, neighbour after neighbour (see the module docstring).

    Args:
        arm: The robot.
        collisions: The checker holding the cell (and the object placement) to avoid.
        start_q: The configuration the first IK of each connected region starts from.
        directions: Unit directions of the candidates from the centre (count, 3).
        targets: The candidates' targets, one per direction.

    Returns:
        Configurations (count, dof) with NaN rows for unusable candidates, and the reasons.
    """
    count = len(targets)
    neighbours = nearest_directions(directions)
    joints = np.full((count, arm.joints.dof), np.nan)
    reasons: list[str | None] = [None] * count
    visited = np.zeros(count, dtype=bool)
    with stage("reachability of the candidates", count, "view") as bar:
        for root in range(count):
            if visited[root]:
                continue
            visited[root] = True
            queue = collections.deque([root])
            while queue:
                index = queue.popleft()
                solved = [n for n in neighbours[index] if not np.isnan(joints[n, 0])]
                seed = joints[solved[0]] if solved else start_q
                result = arm.reach(targets[index], seed, collisions, restarts=SCREEN_RESTARTS)
                if result.reachable:
                    joints[index] = result.q
                else:
                    reasons[index] = result.reason
                bar.update()
                for neighbour in neighbours[index]:
                    if not visited[neighbour]:
                        visited[neighbour] = True
                        queue.append(neighbour)
    return joints, tuple(reasons)


def screen_band(episode: Episode, band: BandCandidates
                ) -> tuple[np.ndarray, tuple[str | None, ...]]:
    """`screen_reachability` of the band candidates from where the episode's robot is (its
    object placement decides what collides); free-flying every candidate is taken, and the
    configurations have no columns."""
    if not episode.uses_robot:
        return np.zeros((len(band), 0)), (None,) * len(band)
    return screen_reachability(episode.scene.arm, episode.robot.collisions, episode.q,
                               band.directions, band.targets)


@dataclasses.dataclass(frozen=True)
class BandCandidates:
    """The model-free candidate views of a cell.

    Attributes:
        targets: Look-at targets at the working distance around the cell's object centre.
        directions: Their unit directions from the centre (count, 3), world axes.
        gains: Their rays through the cell's occupancy grid.
    """

    targets: tuple[SensorTarget, ...]
    directions: np.ndarray
    gains: ViewGains

    def __len__(self) -> int:
        return len(self.targets)


def band_directions() -> np.ndarray:
    """Unit directions (`BAND_COUNT`, 3) of the band candidates from the object's centre."""
    return sphere_directions(BAND_COUNT, np.deg2rad(MAX_POLAR_DEG))


@functools.lru_cache(maxsize=4)
def band_candidates(config: Config, voxel_m: float) -> BandCandidates:
    """The band candidates of a cell and their rays through its grid of `voxel_m` voxels;
    cached, as they depend on the cell and the sensor only."""
    directions = band_directions()
    sensor = SensorModel.from_config(config.sensor)
    targets = look_at_targets(np.asarray(config.cell.object_center_m),
                              sensor.working_distance_m, directions)
    return BandCandidates(targets, directions,
                          ViewGains(OccupancyGrid.for_cell(config, voxel_m), sensor,
                                    [target.pose for target in targets],
                                    sensing=config.sensor.sensing_model))


def request_directions(views: Sequence[ViewRecord], center: np.ndarray) -> np.ndarray:
    """Unit directions (n, 3) from the object's centre to where each view was requested."""
    requested = np.array([view.requested.position - center for view in views]).reshape(-1, 3)
    return requested / np.linalg.norm(requested, axis=1, keepdims=True)


def offered(directions: np.ndarray, requested: np.ndarray, failed: np.ndarray) -> np.ndarray:
    """Which candidates may be requested: none that failed (bool, count) and none within
    `EXCLUDE_DEG` of a requested direction (n, 3; taken or failed)."""
    allowed = ~failed
    if len(requested):
        allowed &= (directions @ requested.T).max(axis=1) < np.cos(np.deg2rad(EXCLUDE_DEG))
    return allowed
