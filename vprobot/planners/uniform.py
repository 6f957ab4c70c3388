"""`uniform<k>`: k fixed look-at views spread evenly over the view band.

The view band is the part of the view sphere (working distance about the fixture's centre,
from the top down to `ground_truth.MAX_POLAR_DEG`, 30 degrees below the equator: where the
inspectable surface is defined from) that the cell can use: free-flying, all of it; with the
robot, the candidates its IK reaches collision-free, with the arm not hiding the view, in the
cell holding the envelope of every object it accepts instead of a part (a sphere of the fit
limit's radius about the fixture's centre, `vprobot.cell.fit`: what the cell knows before a part
arrives). Screened in the empty cell instead, a quarter of the views of `uniform4` collided
with the training motors (the arm reaches around the part). The k views are the
subset of those candidates with the least electrostatic energy (sum of 1 / distance: as far from
each other as the band allows), found by farthest-point sampling and then moving single views to
neighbouring candidates while the energy drops. They depend on k and the cell only: not on the
object, its pose or its mesh.

Where the envelope leaves fewer than k views, the band is screened in the episode's own cell
instead, around the part at its pose (the robot's collision checker holds it, as for every
request; the mesh is not read). The envelope is far larger than the parts it is meant for where
the working distance is long or the arm short: with the Zivid and PhoXi presets (0.6 m and more)
the UR10 reaches no view around the 0.425 m sphere that its column bounds, with the UR5 and
the Panda not even with the paper's sensor; around the bundled motor it reaches hundreds. The
views then depend on the part's placement too.

With the robot, each view is reached from the configuration that reached it in the screening
(the IK checks it against the part's placement and restarts if need be); the reachable ones are
ordered for short joint travel (the others follow and are reported unreachable when
executed); free-flying, they are ordered for a short sensor path. The plan runs to its end: a fixed
pattern does not know the coverage.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from pathlib import Path

import numpy as np
import trimesh

from vprobot.cell.fit import fit_limit
from vprobot.cell.scene import Cell
from vprobot.config import Config
from vprobot.coverage.ground_truth import MAX_POLAR_DEG, robot_digest
from vprobot.episode import Episode, ViewRequest
from vprobot.episode.views import (
    SCREEN_RESTARTS,
    look_at_targets,
    nearest_directions,
    screen_reachability,
)
from vprobot.files.atomic import read_cached_arrays, waiting_lock, write_cached_arrays
from vprobot.files.paths import cache_root
from vprobot.geometry.viewsphere import sphere_directions
from vprobot.kinematics import RobotArm, SensorTarget
from vprobot.kinematics.collision import CollisionChecker
from vprobot.planners.base import Planner, PlanPlanner, check_views, register_planner
from vprobot.planners.candidates import CANDIDATE_COUNT, arm_hides_view
from vprobot.planners.ordering import fixed_plan
from vprobot.planners.self_stopping import SelfStopping


def _band() -> np.ndarray:
    """Unit directions (`CANDIDATE_COUNT`, 3) of the band's candidates from the centre."""
    return sphere_directions(CANDIDATE_COUNT, np.deg2rad(MAX_POLAR_DEG))


def _reachable_band(arm: RobotArm, collisions: CollisionChecker, start_q: np.ndarray,
                    center: np.ndarray, distance: float) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (n, 3) of the band's candidates that the arm reaches in the cell of
    `collisions` with the view of `center` unhidden, and a configuration (n, dof) for each."""
    directions = _band()
    targets = look_at_targets(center, distance, directions)
    joints, _ = screen_reachability(arm, collisions, start_q, directions, targets)
    usable = [index for index, q in enumerate(joints)
              if not np.isnan(q).any() and not arm_hides_view(arm, q, center)]
    return directions[usable], joints[usable]


VIEW_BAND_METHOD = 1
"""Bumped when the screening would find other candidates: cached bands of another are not read."""


@functools.lru_cache(maxsize=4)
def view_band(config: Config, robot: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Unit directions (n, 3) of the band's candidates the cell can use (see the module
    docstring) and, with the robot, a configuration (n, dof) reaching each around the cell's
    object envelope. They depend on the cell only, so the robot's are kept in vprobot's cache
    (`paths.cache_root()`, `view_band/`): screening them is minutes of motion planning."""
    if not robot:
        return _band(), None
    path = cache_root() / "view_band" / f"{_view_band_key(config)}.npz"
    # Processes starting at once (an evaluation's workers) screen it once: the others wait.
    with waiting_lock(path.with_suffix(".lock")):
        stored = _read_view_band(path)
        if stored is not None:
            return stored
        envelope = trimesh.creation.icosphere(subdivisions=3, radius=fit_limit(config).radius_m)
        arm = RobotArm(Cell(config, envelope))
        directions, joints = _reachable_band(
            arm, arm.collisions, arm.joints.start,
            np.asarray(config.cell.object_center_m, dtype=float),
            config.sensor.working_distance_m)
        write_cached_arrays(path, {"directions": directions, "joints": joints}, "view bands")
    return directions, joints


def _view_band_key(config: Config) -> str:
    """What shapes a cell's view band: the cell, the kinematics, the sensor's geometry (its
    housing and mount collide; its resolution and sensing model do not matter) and the robot's
    files."""
    sensor = tuple(getattr(config.sensor, field.name)
                   for field in dataclasses.fields(config.sensor)
                   if field.name not in ("resolution", "sensing", "structured_light",
                                         "acquisition_time_s"))
    settings = (VIEW_BAND_METHOD, CANDIDATE_COUNT, MAX_POLAR_DEG, SCREEN_RESTARTS,
                dataclasses.astuple(config.cell), dataclasses.astuple(config.kinematics), sensor,
                robot_digest(config.cell.robot))
    return hashlib.sha256(repr(settings).encode()).hexdigest()[:32]


def _read_view_band(path: Path) -> tuple[np.ndarray, np.ndarray] | None:
    """The view band cached at `path`, or None when there is none or it does not hold band
    directions and a finite configuration for each (then it is recomputed)."""
    arrays = read_cached_arrays(path)
    if arrays is None or set(arrays) != {"directions", "joints"}:
        return None
    directions, joints = arrays["directions"], arrays["joints"]
    band = _band()
    if (directions.dtype != np.float64 or directions.ndim != 2 or directions.shape[1:] != (3,)
            or joints.dtype != np.float64 or joints.ndim != 2 or len(joints) != len(directions)
            or not np.isfinite(joints).all()
            or not all(np.isclose(band, row).all(axis=1).any() for row in directions)):
        return None
    return directions, joints


def episode_band(config: Config, episode: Episode) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (n, 3) of the band's candidates the robot reaches around the episode's
    part at its pose, screened from its current configuration, and a configuration (n, dof)
    for each."""
    return _reachable_band(episode.scene.arm, episode.robot.collisions, episode.q,
                           episode.center, config.sensor.working_distance_m)


def _energy(points: np.ndarray) -> float:
    distance = np.linalg.norm(points[:, None] - points[None], axis=-1)
    upper = np.triu_indices(len(points), 1)
    return float(np.sum(1.0 / np.maximum(distance[upper], 1e-12)))


def spread(directions: np.ndarray, count: int) -> np.ndarray:
    """Indices of `count` of `directions` spread evenly: least energy found from farthest-point
    sampling (started at the topmost) by single moves to neighbouring directions.

    Raises:
        ValueError: If count < 1 or exceeds the directions.
    """
    if not 1 <= count <= len(directions):
        raise ValueError(f"count must lie in 1..{len(directions)}, got {count}")
    chosen = [int(np.argmax(directions[:, 2]))]
    nearest = np.linalg.norm(directions - directions[chosen[0]], axis=1)
    while len(chosen) < count:
        chosen.append(int(np.argmax(nearest)))
        nearest = np.minimum(nearest, np.linalg.norm(directions - directions[chosen[-1]], axis=1))
    neighbours = nearest_directions(directions)
    best = _energy(directions[chosen])
    improved = True
    while improved:
        improved = False
        for slot in range(count):
            for candidate in neighbours[chosen[slot]]:
                if candidate in chosen:
                    continue
                trial = chosen[:slot] + [int(candidate)] + chosen[slot + 1:]
                energy = _energy(directions[trial])
                if energy < best - 1e-12:
                    chosen, best, improved = trial, energy, True
    return np.array(chosen)


def uniform_targets(config: Config, count: int, episode: Episode
                    ) -> tuple[list[SensorTarget], np.ndarray | None]:
    """The `count` look-at targets of `uniform<count>` in the episode's cell, and with the
    robot the configurations reaching them (see the module docstring for where).

    Raises:
        ValueError: If count < 1, or exceeds the band's usable candidates around the part too.
    """
    band, joints = view_band(config, episode.uses_robot)
    center = np.asarray(config.cell.object_center_m, dtype=float)
    if episode.uses_robot and count > len(band):
        enveloped = len(band)
        band, joints = episode_band(config, episode)
        center = episode.center
        if count > len(band):
            fewer = f"uniform{len(band)} or fewer, " if len(band) else ""
            raise ValueError(f"uniform{count} needs {count} views of the band, but only "
                             f"{len(band)} are usable with robot {config.cell.robot!r} and this "
                             f"sensor (working distance {config.sensor.working_distance_m:g} m) "
                             f"around this part at its pose ({enveloped} around the largest "
                             f"object the cell fits, radius {fit_limit(config).radius_m:.3f} m); "
                             f"use {fewer}a robot or placement that reaches the working "
                             f"distance, or --carrier free")
    chosen = spread(band, count)
    targets = look_at_targets(center, config.sensor.working_distance_m, band[chosen])
    return list(targets), None if joints is None else joints[chosen]


@register_planner
class UniformPlanner(SelfStopping, PlanPlanner):
    """k fixed views spread over the view band, in a short travel order, run to their end (not
    stopped at the goal).

    Args:
        config: The configuration (cell, robot, sensor).
        count: Number of views k.

    Raises:
        ValueError: If count is not in 1..MAX_VIEWS.
    """

    name = "uniform"
    pattern = r"(?P<count>[1-9]\d*)"
    usage = "uniform<k>"
    evaluated = ("uniform4", "uniform5", "uniform6")

    def __init__(self, config: Config, count: int):
        check_views(count, "the view count k of uniform<k>")
        super().__init__()
        self.config = config
        self.count = count

    @classmethod
    def from_name(cls, config: Config, views: int | None = None, **params: str) -> Planner:
        return cls(config, int(params["count"]))

    def plan(self, episode: Episode) -> list[ViewRequest]:
        return fixed_plan(episode, *uniform_targets(self.config, self.count, episode))
